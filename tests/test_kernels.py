"""The compiled kernels (humanoid/kernels.c) against the NumPy path they replace.

The ground's detection in C must find the same contacts, in the same order, at the same
points, with the same Jacobian rows, as ``Ground._detect`` and ``Ground.jacobian`` (which
tests/test_ground.py holds to Pinocchio's geometry placements and its point-contact
Jacobians): on every kind of joint the kernel places, every kind of candidate point (box and
hull vertices, sphere and capsule bottoms, cylinder rims), a hull with more points near the
floor than a geometry keeps, and the pelvis turned at random.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model, random_state

from humanoid.constraints import ground as G
from humanoid.constraints.ground import Ground, GroundSettings

pytestmark = pytest.mark.skipif(G.KERNELS is None, reason="humanoid.kernels is not built")


def _random_q(model: pin.Model, rng: np.random.Generator, height: float) -> np.ndarray:
    """A random configuration in the joints' limits (2 rad at most), the root turned at random
    and its origin ``height`` above the floor, give or take."""
    lo = np.maximum(model.lowerPositionLimit, -2.0)
    hi = np.minimum(model.upperPositionLimit, 2.0)
    q = pin.randomConfiguration(model, lo, hi)
    if model.joints[1].shortname() == "JointModelFreeFlyer":
        q[:3] = [rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-0.3, height)]
        q[3:7] = pin.Quaternion(pin.exp3(rng.normal(size=3))).coeffs()
    return q


def _same_contacts(ground: Ground, model: pin.Model, q: np.ndarray) -> int:
    """The compiled contacts at q equal the NumPy path's; returns how many there are."""
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    want = ground._detect(data)
    got = ground._compiled(q)
    np.testing.assert_array_equal(got.joints, want.joints)
    np.testing.assert_allclose(got.points, want.points, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(got.phi, got.points[:, 2])
    np.testing.assert_allclose(got.local, want.local, rtol=0, atol=1e-12)
    assert got.rows is not None
    np.testing.assert_allclose(got.rows, ground.jacobian(data, want), rtol=0, atol=1e-12)
    return len(got)


@pytest.mark.parametrize("name", ["male", "human", "talos"])
@pytest.mark.parametrize("mode", ["quaternion", "euler"])
def test_the_compiled_detection_finds_the_numpy_paths_contacts(name, mode):
    """Every collision geometry of the body (the visual meshes' hulls for erd's human) near the
    floor in 300 random postures: the same contacts to 1e-12 m, and among them geometries
    with more points near the floor than they keep (the support polygon's extremes)."""
    h = get_model(name, mode)
    geometry = h.collision_model if h.collision_model.ngeoms else h.visual_model
    ground = Ground(h.model, geometry, range(geometry.ngeoms), GroundSettings(margin=0.05))
    assert ground.compiled
    rng = np.random.default_rng(11)
    found = [_same_contacts(ground, h.model, _random_q(h.model, rng, 1.0)) for _ in range(300)]
    assert sum(found) > 300


def _chain() -> tuple[pin.Model, pin.GeometryModel]:
    """Every joint kind the kernel places, and every kind of candidate point: a free base, a
    ball, a continuous hinge, an unaligned hinge and an unaligned slider, each carrying a
    sphere, a capsule, a cylinder, a box or a convex hull of 400 points."""
    model, geometry = pin.Model(), pin.GeometryModel()
    rng = np.random.default_rng(5)
    joints = [pin.JointModelFreeFlyer(), pin.JointModelSpherical(), pin.JointModelRUBY(),
              pin.JointModelRevoluteUnaligned(np.array([0.6, 0.0, 0.8])),
              pin.JointModelPrismaticUnaligned(np.array([0.0, 0.8, 0.6])), pin.JointModelRZ(),
              pin.JointModelPX()]  # fmt: skip
    cloud = rng.normal(size=(400, 3)) * [0.1, 0.05, 0.02]
    hull = coal.BVHModelOBBRSS()
    hull.beginModel(0, len(cloud))
    hull.addVertices(cloud)
    hull.endModel()
    hull.buildConvexHull(True, "Qt")
    shapes = [coal.Sphere(0.05), coal.Capsule(0.04, 0.2), coal.Cylinder(0.05, 0.1),
              coal.Box(0.1, 0.2, 0.05), hull.convex, coal.Cylinder(0.03, 0.3),
              coal.Box(0.05, 0.05, 0.05)]  # fmt: skip
    parent = 0
    for i, (jm, shape) in enumerate(zip(joints, shapes, strict=True)):
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.1, size=3))
        parent = model.addJoint(parent, jm, placement, f"j{i}")
        model.appendBodyToJoint(parent, pin.Inertia.Random(), pin.SE3.Identity())
        where = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.05, size=3))
        geometry.addGeometryObject(pin.GeometryObject(f"g{i}", parent, where, shape))
    model.lowerPositionLimit[:] = -1.0
    model.upperPositionLimit[:] = 1.0
    return model, geometry


def test_the_compiled_detection_places_every_joint_kind_and_shape():
    """The chain of :func:`_chain` in 500 random postures: the same contacts, and the joint
    placements Pinocchio's forward kinematics gives (1e-12)."""
    model, geometry = _chain()
    ground = Ground(model, geometry, range(geometry.ngeoms), GroundSettings(margin=0.3))
    assert ground.compiled
    rng = np.random.default_rng(6)
    data = model.createData()
    R, t = np.empty((model.njoints, 9)), np.empty((model.njoints, 3))
    found = 0
    for _ in range(500):
        q = _random_q(model, rng, 0.5)
        found += _same_contacts(ground, model, q)
        pin.forwardKinematics(model, data, q)
        G.KERNELS.placements(ground._plan, q, R, t)
        for j in range(model.njoints):
            np.testing.assert_allclose(R[j].reshape(3, 3), data.oMi[j].rotation, atol=1e-12)
            np.testing.assert_allclose(t[j], data.oMi[j].translation, atol=1e-12)
    assert found > 500


def test_a_joint_the_kernel_does_not_place_keeps_the_numpy_path():
    """A planar joint (not placed by the kernel): the ground detects on the NumPy path, as
    with ``compiled=False``; and detect without the configuration does too."""
    model, geometry = pin.Model(), pin.GeometryModel()
    j = model.addJoint(0, pin.JointModelPlanar(), pin.SE3.Identity(), "planar")
    model.appendBodyToJoint(j, pin.Inertia.Random(), pin.SE3.Identity())
    geometry.addGeometryObject(pin.GeometryObject("box", j, pin.SE3.Identity(),
                                                  coal.Box(0.1, 0.1, 0.1)))  # fmt: skip
    assert not Ground(model, geometry, [0]).compiled
    male = get_model("male", "quaternion")
    assert not Ground(male.model, male.collision_model, [0], compiled=False).compiled
    data = male.model.createData()
    q = male.standing_configuration()
    pin.computeJointJacobians(male.model, data, q)
    ground = Ground(male.model, male.collision_model, range(male.collision_model.ngeoms))
    assert ground.detect(male.model, data).rows is None  # no configuration: NumPy's
    assert ground.detect(male.model, data, at=q).rows is not None


def test_the_plan_refuses_arrays_of_the_wrong_size():
    """A plan built from arrays of the wrong length is refused with the array named."""
    with pytest.raises(ValueError, match="parent"):
        G.KERNELS.ground_plan(3, 7, 6, 0, 0, 0, 8, 10.0, 1e-3,
                              *([np.zeros(2, dtype=np.int64)] * 15))  # fmt: skip


@pytest.mark.parametrize("name", ["male", "human", "talos"])
@pytest.mark.parametrize("mode", ["quaternion", "euler"])
def test_the_compiled_range_rows_are_the_numpy_paths(name, mode):
    """Every hinge's and every ball joint's range rows (erd's human: ZXY triplets; Talos:
    hinges alone) in 300 random postures, in and out of the ranges, at the margins the
    package uses and with none: the same rows in the same order to 1e-13, each call's angles
    the next one's hint on both paths."""
    from humanoid.constraints.limits import JointRanges

    h = get_model(name, mode)
    compiled, numpy_path = JointRanges(h), JointRanges(h, compiled=False)
    assert compiled._plan is not None and numpy_path._plan is None
    rng = np.random.default_rng(12)
    rows = 0
    for i in range(300):
        q, _ = random_state(h, rng, inside_limits=bool(i % 2))
        for margin in (0.1, 0.0, None):
            r1, J1 = compiled.rows(q, margin=margin)
            r2, J2 = numpy_path.rows(q, margin=margin, certified=False)
            assert r1.shape == r2.shape
            np.testing.assert_allclose(r1, r2, rtol=0, atol=1e-13)
            np.testing.assert_allclose(J1, J2, rtol=0, atol=1e-13)
            rows += len(r1)
    assert rows > 1000
