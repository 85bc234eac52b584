"""The compiled kernels (humanoid/kernels.c) against the NumPy path they replace.

The ground's detection in C must find the same contacts, in the same order, at the same
points, with the same Jacobian rows, as ``Ground._detect`` and ``Ground.jacobian`` (which
tests/test_ground.py holds to Pinocchio's geometry placements and its point-contact
Jacobians): on every kind of joint the kernel places, every kind of candidate point (box and
hull vertices, sphere and capsule bottoms, cylinder rims), a hull with more points near the
floor than a geometry keeps, and the pelvis turned at random.
"""

from __future__ import annotations

from types import SimpleNamespace

import coal
import numpy as np
import pinocchio as pin
import pytest
from conftest import SCENES, get_model, random_state
from test_ground import BOX, G0, _box, _run

from humanoid.constraints import ground as G
from humanoid.constraints.ground import Ground, GroundSettings
from humanoid.errors import ModelError
from humanoid.scene import Scene

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
    assert got.rows is not None and ground.jacobian(data, got) is got.rows
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


def _natural_residual(G, g, lam, nc: int, mu: float) -> float:
    """|lam - P_K(lam - (sigma + s))|_inf with sigma = G lam + g and s the De Saxce term, in
    NumPy (the kernel's own stopping test, written again): zero exactly at a solution."""
    sigma = G @ lam + g
    worst = 0.0
    for c in range(nc):
        z, t = lam[3 * c : 3 * c + 3], sigma[3 * c : 3 * c + 3]
        w = z - t - np.array([0.0, 0.0, mu * np.hypot(t[0], t[1])])
        tn, n = np.hypot(w[0], w[1]), w[2]
        if tn > mu * n:  # outside the cone: onto its edge, or its apex
            beta = max(0.0, (mu * tn + n) / (mu * mu + 1.0))
            w = np.array([mu * beta * w[0] / tn, mu * beta * w[1] / tn, beta])
        worst = max(worst, np.abs(z - w).max())
    rows = slice(3 * nc, len(lam))
    return max(worst, float(np.abs(np.minimum(lam[rows], sigma[rows])).max(initial=0.0)))


def test_the_compiled_admm_solves_the_falls_problems():
    """Every contact solve of the first 0.4 s of the drop (the landing, many new contacts,
    the ranges) by the compiled ADMM, each from the last step's impulses: where it says it
    converged, its impulses solve the scaled problem to its tolerance (the residual written
    again in NumPy, times the stall floor), and the step's velocity is v_free + M^-1 J^T lam
    to 1e-12; where it did not, the step was handed to Pinocchio's ADMM. A wrong start (the
    impulses of other points) still converges to the same velocities as a start from zero."""
    from humanoid.simulation import Simulation

    scene = Scene.load(SCENES / "drop.toml").replace(duration=0.4)
    sim = Simulation(scene)
    solver = sim.plant.ground.solver
    assert solver.settings.solver == "kernel"
    seen = []
    solve = G.KERNELS.contact_solve

    def recorded(J, Minv, v_free, gap, nc, mu, tol, rho, iters, mem, screen, lam, v):
        start = lam.copy()
        out = solve(J, Minv, v_free, gap, nc, mu, tol, rho, iters, mem, screen, lam, v)
        seen.append((J.copy(), Minv.copy(), v_free.copy(), gap.copy(), nc, mu, tol, start,
                     lam.copy(), v.copy(), out))  # fmt: skip
        return out

    original = G.KERNELS
    G.KERNELS = SimpleNamespace(**{k: getattr(original, k) for k in dir(original)
                                   if not k.startswith("__")})  # fmt: skip
    G.KERNELS.contact_solve = recorded
    try:
        sim.run(quiet=True)
    finally:
        G.KERNELS = original
    converged = 0
    for J, Minv, v_free, gap, nc, mu, tol, _, lam, v, (_, ok, residual, *_) in seen:
        np.testing.assert_allclose(v, v_free + Minv @ J.T @ lam, rtol=0, atol=1e-12)
        if not ok:
            continue
        converged += 1
        Gm = J @ Minv @ J.T
        d = np.diag(Gm).copy()
        d[: 3 * nc] = np.repeat(d[: 3 * nc].reshape(-1, 3).mean(axis=1), 3)
        d = 1.0 / np.sqrt(np.maximum(d, 1e-12 * d.max()))
        r = _natural_residual(d[:, None] * Gm * d[None, :], d * (J @ v_free + gap), lam / d,
                              nc, mu)  # fmt: skip
        assert r <= 100 * tol * (1 + 1e-9) and r == pytest.approx(residual, rel=1e-6, abs=1e-15)
    assert len(seen) == 400 and converged >= 390 and solver.fallbacks == len(seen) - converged
    assert sum(out[3] for *_, out in seen) > 100  # rows left out of the solves (speculative)
    # a start from other points' impulses: the same velocities as from zero, to the tolerance
    J, Minv, v_free, gap, nc, mu, tol, *_ = seen[200]
    v0, v1 = np.empty_like(v_free), np.empty_like(v_free)
    rng = np.random.default_rng(3)
    for v, lam in ((v0, np.zeros(len(gap))), (v1, rng.uniform(0, 1, len(gap)))):
        assert G.KERNELS.contact_solve(J, Minv, v_free, gap, nc, mu, 1e-10, 1.0, 2000, 3, 0.1,
                                       lam, v)[1]  # fmt: skip
    np.testing.assert_allclose(v0, v1, rtol=0, atol=1e-6)


@pytest.mark.parametrize("mu", [0.8, 0.1])
def test_a_box_at_rest_carries_its_weight_and_no_sideways_force(mu):
    """A 1 kg box resting on its four corners for 1 s, the compiled ADMM warm-started at
    every step (where Pinocchio's ADMM, started from the last impulses, stopped with the
    normal impulse 4e-5 of the weight off, and kept a sideways force of 2e-6 of it on ice):
    the floor carries its weight to 1e-6 relative and pushes it sideways by less than 2e-7 of
    it (3e-7 and 7e-8 measured: the tolerance, 1e-9 on the scaled velocities, is 3e-9 m/s on
    this box, 3e-7 of a step's weight impulse); it does not move (1e-10 m), and no step is
    handed over."""
    model, solver = _box(mu, solver="kernel")
    q = pin.neutral(model)
    q[2] = BOX[2] / 2
    states = _run(model, solver, q, np.zeros(6), 1.0, 1e-3)
    weight = G0 * 1e-3  # [N s] a step's
    for _, _, found in states[-100:]:
        f = found.impulses.sum(axis=0)
        assert abs(f[2] - weight) < 1e-6 * weight and np.hypot(f[0], f[1]) < 2e-7 * weight
    assert np.abs(states[-1][0] - q).max() < 1e-10
    assert solver.fallbacks == 0 and solver.failures == 0


def test_a_row_left_out_that_the_solution_pushes_through_is_solved_again():
    """A rigid bar (1 kg, a small inertia) whose end A lands at 1 m/s while its other end B,
    1.2 mm up, would stay off the floor in the free motion (B's row left out of the solve):
    A's impulse tips the bar and drives B through the floor, so the step is solved again with
    B, and the answer is the whole problem's (the same velocities to 1e-9 as with no row left
    out); a point far above stays out."""
    Minv = np.diag([1.0, 1.0, 1.0, 100.0, 100.0, 100.0])  # mass 1 kg, inertia 0.01 kg m^2

    def rows(p):  # v_p = v + w x p, world axes at the identity
        skew = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
        return np.hstack([np.eye(3), -skew])

    v_free = np.array([0.0, 0.0, -1.0, 0.0, 0.0, 0.0])
    J = np.vstack([rows(np.array([0.5, 0.0, 0.0])), rows(np.array([-0.5, 0.0, 0.0]))])
    out = {}
    for phi_b, screen in ((1.2e-3, 0.1), (1.2e-3, np.inf), (3.0, 0.1), (3.0, np.inf)):
        gap = np.array([0.0, 0.0, 0.0, 0.0, 0.0, phi_b / 1e-3])
        lam, v = np.zeros(6), np.zeros(6)
        its, ok, _, left_out, again = G.KERNELS.contact_solve(
            J, Minv, v_free, gap, 2, 0.8, 1e-12, 1.0, 2000, 3, screen, lam, v)  # fmt: skip
        assert ok
        out[phi_b, screen] = (v, lam, left_out, again)
    v, lam, left_out, again = out[1.2e-3, 0.1]
    assert left_out == 3 and again and lam[5] > 0  # B was left out, then carried load
    np.testing.assert_allclose(v, out[1.2e-3, np.inf][0], rtol=0, atol=1e-9)
    v, lam, left_out, again = out[3.0, 0.1]
    assert left_out == 3 and not again and lam[5] == 0.0
    np.testing.assert_allclose(v, out[3.0, np.inf][0], rtol=0, atol=1e-9)


def test_the_steps_handed_over_go_to_the_configured_admm():
    """The compiled solver hands its hard steps to Pinocchio's ADMM as ``solver = "admm"``
    configures it (the spectral update rule, the short Lanczos estimate), not to its
    defaults (an OSQP-like rule, a Lanczos estimate as long as the problem)."""
    from humanoid.constraints.ground import ContactSolver

    model, _ = _box(0.5)
    settings = GroundSettings(solver="kernel", lanczos=7)
    handed = ContactSolver(model, None, None, settings).solve_settings
    assert handed.admm_update_rule == pin.ADMMUpdateRule.SPECTRAL
    assert handed.lanczos_size == 7


def _tree_dynamics_agrees(model: pin.Model, rng: np.random.Generator, states: int) -> None:
    """TreeDynamics at random states (a turned, moving root) against Pinocchio's forward
    kinematics and RNEA: placements 1e-12; angular velocities, the joints' forces and moments
    (world axes, about each joint's origin) and tau to 1e-9 of their size."""
    from humanoid.dynamics import TreeDynamics

    tree = TreeDynamics(model)
    assert tree.available
    q = np.array([_random_q(model, rng, 1.0) for _ in range(states)])
    v = rng.normal(size=(states, model.nv))
    a = rng.normal(size=(states, model.nv)) * 5.0
    got = tree(q, v, a)
    data = model.createData()
    for i in range(states):
        pin.forwardKinematics(model, data, q[i], v[i], a[i])
        tau = pin.rnea(model, data, q[i], v[i], a[i])
        size = max(1.0, np.abs(tau).max())
        np.testing.assert_allclose(got.tau[i], tau, rtol=0, atol=1e-9 * size)
        for j in range(1, model.njoints):
            R = data.oMi[j].rotation
            np.testing.assert_allclose(got.R[i, j], R, rtol=0, atol=1e-12)
            np.testing.assert_allclose(got.t[i, j], data.oMi[j].translation, rtol=0, atol=1e-12)
            np.testing.assert_allclose(got.w[i, j], R @ data.v[j].angular, rtol=0, atol=1e-9)
            np.testing.assert_allclose(got.m[i, j], R @ data.f[j].angular, rtol=0,
                                       atol=1e-9 * size)  # fmt: skip
            np.testing.assert_allclose(got.f[i, j], R @ data.f[j].linear, rtol=0,
                                       atol=1e-9 * size)  # fmt: skip


@pytest.mark.parametrize("name", ["male", "human", "talos"])
@pytest.mark.parametrize("mode", ["quaternion", "euler"])
def test_the_compiled_inverse_dynamics_is_pinocchios(name, mode):
    model = get_model(name, mode).model
    _tree_dynamics_agrees(model, np.random.default_rng(21), 40)


def test_the_compiled_inverse_dynamics_moves_every_joint_kind():
    """The chain of :func:`_chain` (free, ball, continuous and unaligned hinges, unaligned and
    aligned sliders), its gravity turned off the vertical."""
    model, _ = _chain()
    model.gravity.linear = np.array([1.0, -2.0, -9.0])
    _tree_dynamics_agrees(model, np.random.default_rng(22), 200)


def test_a_model_the_kernels_do_not_place_has_no_tree_dynamics():
    from humanoid.dynamics import TreeDynamics

    model = pin.Model()
    j = model.addJoint(0, pin.JointModelPlanar(), pin.SE3.Identity(), "planar")
    model.appendBodyToJoint(j, pin.Inertia.Random(), pin.SE3.Identity())
    tree = TreeDynamics(model)
    assert not tree.available
    with pytest.raises(ModelError, match="not available"):
        tree(np.zeros((1, model.nq)), np.zeros((1, model.nv)), np.zeros((1, model.nv)))


def test_the_gait_records_compiled_kinetics_are_pinocchios():
    """GaitRecorder.record with its compiled kinematics and RNEA and with Pinocchio's, on 60
    steps of random states with random ground forces on the feet (a rotated, moving pelvis):
    the same forces, centres of pressure, loads, slips and joint moments and powers."""
    from humanoid.walking.gait import GaitRecorder

    h = get_model("male", "quaternion")
    model = h.model
    rng = np.random.default_rng(23)
    rec = GaitRecorder(h, model)
    feet = [model.frames[h.sole_id(s)].parentJoint for s in ("left", "right")]
    dt = 1e-3
    for k in range(60):
        q, v = random_state(h, rng)
        step = SimpleNamespace(q=pin.integrate(model, q, dt * v), v=v + rng.normal(size=model.nv))
        n = int(rng.integers(0, 9))
        joints = rng.choice(feet, size=n)
        local = rng.normal(size=(n, 3)) * 0.05
        data = model.createData()
        pin.forwardKinematics(model, data, q)
        points = np.array([data.oMi[int(j)].act(r) for j, r in zip(joints, local, strict=True)])
        impulses = np.column_stack([rng.normal(size=(n, 2)), rng.uniform(-0.1, 1.0, n)])
        found = SimpleNamespace(points=points.reshape(n, 3), joints=joints, local=local,
                                impulses=impulses * dt * 300.0)  # fmt: skip
        sim = SimpleNamespace(scene=SimpleNamespace(dt=dt), ground_step=found if n else None)
        rec.observe(sim, k, k * dt, q, v, step)
    compiled = rec.record(h.mass, dt)
    rec._tree = SimpleNamespace(available=False)
    stepwise = rec.record(h.mass, dt)
    for key in ("force", "cop", "heel", "toe", "slip", "kinetics"):
        for side in ("left", "right"):
            a, b = getattr(compiled, key)[side], getattr(stepwise, key)[side]
            np.testing.assert_allclose(np.asarray(a, float), np.asarray(b, float), rtol=1e-9,
                                       atol=1e-9)  # fmt: skip
    assert np.abs(compiled.kinetics["left"]).max() > 10.0  # real moments, not zeros
    assert compiled.heel["left"].any() and compiled.toe["right"].any()


@pytest.mark.parametrize("name", ["male", "male_foot"])
def test_the_compiled_held_torques_are_pinocchios(name):
    """The welded walk's torques between QP ticks (WalkingController.held_torques) from the
    compiled kernel and from Pinocchio's calls, after a solve with two feet welded (the male
    body's toes locked beside its soles; ``male_foot``: one-piece feet, no locks), at 30 states
    away from it: the pelvis turned and moved, the welds half a radian and centimetres off
    their anchors (the general branch of the SE3 log), random velocities that send hinges
    through their dampers' floors, and three ball joints' range rows held. The same tau to
    1e-9 of its size, the free flyer's rows zero."""
    from humanoid.walking import run as walk_run
    from humanoid.walking.plan import GaitParameters

    h = get_model(name, "quaternion")
    setup = walk_run.prepare(h, GaitParameters(steps=2))
    ctl, sim, model = setup.ctl, setup.sim, h.model
    ctl.every, ctl.period = 8, 8e-3
    ctl.before_step(sim, 0, 0.0, setup.q0, setup.v0)
    held, holds = ctl._stance[2], ctl._holds
    assert holds.packed is not None and holds.tree is not None
    ints = holds.packed[0]  # the counts, the corners' joints, then 3 ints per weld or lock
    kinds = ints[5 + ints[0] : 5 + ints[0] + 3 * ints[1] : 3]
    locks = int(np.count_nonzero(kinds == 1))
    assert locks == (2 if name == "male" else 0)
    dv, _, Jh_dv = ctl._held
    Jr = ctl.ranges.rows(setup.q0, margin=2.0)[1]
    Jr = Jr[np.count_nonzero(Jr, axis=1) > 1][:3]  # ball joints' (a hinge's may repeat a floor)
    assert len(Jr) == 3
    ctl._held = (dv, Jr, Jh_dv)
    stance = ["left", "right"]
    forces = np.concatenate([ctl.last[1][s] for s in stance])
    holds.hold(ctl, stance, ctl._stance[1], forces, Jr, Jh_dv)
    rng = np.random.default_rng(37)
    short = 0
    for _ in range(30):
        q = pin.integrate(model, setup.q0, rng.normal(size=model.nv) * 0.2)
        v = rng.normal(size=model.nv)
        compiled = ctl.held_torques(q, v, held)
        packed, holds.packed = holds.packed, None
        reference = ctl.held_torques(q, v, held)
        holds.packed = packed
        np.testing.assert_allclose(compiled, reference, rtol=0,
                                   atol=1e-9 * np.abs(reference).max())  # fmt: skip
        assert not compiled[:6].any()
        r, _ = ctl.ranges.hinge_rows(q)
        floor = (-r / 0.05 - ctl._hinge_sign * v[ctl._hinge_v]) * (ctl.every / ctl.period)
        short += int(np.count_nonzero(Jh_dv < floor))
    assert short > 0  # the hinges' rows were exercised


@pytest.mark.parametrize("name", ["male", "talos"])
def test_the_compiled_weld_and_lock_rows_are_stacks(name):
    """TreeDynamics.constraint_rows against humanoid.constraints.solve.stack on Pinocchio's
    kinematics: both soles welded to anchors half a radian and centimetres off (the SE3 log's
    general branch), the male body's MTP hinges locked between them (the order of a welded
    foot's constraints), at 20 random states with the pelvis turned, with Baumgarte gains and
    without: J and gamma to 1e-12 of their size. A weld turned half a turn is handed back."""
    from humanoid.constraints import JointLock, Weld
    from humanoid.constraints.foot import foot_hinges, packed_rows
    from humanoid.constraints.solve import Baumgarte, stack
    from humanoid.dynamics import TreeDynamics

    h = get_model(name, "quaternion")
    model, data = h.model, h.model.createData()
    rng = np.random.default_rng(41)
    pin.seed(41)  # (_random_q's joints: the same states whatever ran before in the process)
    constraints = []
    for side in ("left", "right"):
        sole = h.sole_id(side)
        anchor = pin.SE3(pin.exp3(rng.normal(size=3) * 0.3), rng.normal(size=3) * 0.05)
        constraints.append(Weld(f"{side}_weld", sole, anchor))
        points = [h.frame_id(n) for n in h.require_contact_points(side)]
        for j in foot_hinges(model, sole, points):
            constraints.append(JointLock(f"{side}_lock", model, j, rng.uniform(-0.3, 0.3)))
    locks = sum(isinstance(c, JointLock) for c in constraints)
    assert locks == (2 if name == "male" else 0)
    tree = TreeDynamics(model)
    packed = packed_rows(model, constraints)
    assert packed is not None
    for gains in (Baumgarte(50.0, 50.0), Baumgarte()):
        rows = tree.rows_of(packed, gains)
        for _ in range(10):
            q = _random_q(model, rng, 1.0)
            v = rng.normal(size=model.nv)
            pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
            pin.computeJointJacobians(model, data, q)
            pin.updateFramePlacements(model, data)
            J, gamma = stack(model, data, constraints, v, gains)
            got = tree.constraint_rows(q, v, rows)
            turns = [np.linalg.norm(pin.log3(c.anchor.rotation.T @ data.oMf[c.frame_id].rotation))
                     for c in constraints if isinstance(c, Weld)]  # fmt: skip
            if max(turns) > np.pi - 0.1:  # the log's axis loses digits: stack them
                assert got is None
                continue
            assert got is not None
            np.testing.assert_allclose(got[0], J, rtol=0, atol=1e-12 * np.abs(J).max())
            np.testing.assert_allclose(got[1], gamma, rtol=0, atol=1e-12 * np.abs(gamma).max())
    q = pin.neutral(model)
    pin.framesForwardKinematics(model, data, q)
    turned = data.oMf[h.sole_id("left")] * pin.SE3(pin.exp3(np.array([0, 0, np.pi])), np.zeros(3))
    half = Weld("turned", h.sole_id("left"), turned)
    rows = tree.rows_of(packed_rows(model, [half]), Baumgarte(1.0, 1.0))
    assert tree.constraint_rows(q, np.zeros(model.nv), rows) is None
