"""The foot with toes (``BodyParameters(..., toes=True)``): the rearfoot and the toes on the
metatarsophalangeal hinge together are de Leva's foot; frames, signs, ranges, passive
properties, and what the loader makes of the body."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import humanoid as hm
from humanoid.anthropometry import TOES, body_dimensions, segments
from humanoid.body import JOINT_RANGES, PASSIVE_JOINTS
from humanoid.errors import BodyParameterError

SIDES = ("left", "right")
BODIES = [(1.75, 75.0, "male"), (1.62, 62.0, "female"), (1.50, 45.0, "female"), (1.95, 100, "male")]
IDS = [f"{s}-{h}m-{m}kg" for h, m, s in BODIES]


def _models(h, m, sex):
    """Pinocchio models of the same person with and without toes (Euler joints)."""
    return tuple(
        pin.buildModelFromXML(
            hm.build_urdf(hm.BodyParameters(h, m, sex, toes=toes)), pin.JointModelFreeFlyer()
        )
        for toes in (False, True)
    )


def _composite(model, data, joints):
    """Mass, CoM and inertia about the CoM (world axes) of the bodies on ``joints``."""
    total = pin.Inertia.Zero()
    for j in joints:
        total += data.oMi[j].act(model.inertias[j])
    return total.mass, total.lever, total.inertia


@pytest.mark.parametrize(("h", "m", "sex"), BODIES, ids=IDS)
def test_rearfoot_and_toes_together_are_de_levas_foot(h, m, sex):
    """At an MTP angle of zero the two parts' mass, CoM and inertia about the CoM equal the
    one-piece foot's to round-off, and the whole body's mass and CoM are unchanged."""
    plain, toes = _models(h, m, sex)
    for model in (plain, toes):
        model.data = model.createData()
        pin.forwardKinematics(model, model.data, pin.neutral(model))
    for side in SIDES:
        one = _composite(plain, plain.data, [plain.getJointId(f"{side}_ankle_inversion")])
        two = _composite(
            toes,
            toes.data,
            [toes.getJointId(f"{side}_ankle_inversion"), toes.getJointId(f"{side}_mtp")],
        )
        assert math.isclose(one[0], two[0], rel_tol=1e-12)
        np.testing.assert_allclose(two[1], one[1], atol=1e-12)
        np.testing.assert_allclose(two[2], one[2], atol=1e-12)
    assert math.isclose(pin.computeTotalMass(toes), m, rel_tol=1e-12)
    np.testing.assert_allclose(
        pin.centerOfMass(toes, toes.data, pin.neutral(toes)),
        pin.centerOfMass(plain, plain.data, pin.neutral(plain)),
        atol=1e-12,
    )


@pytest.mark.parametrize(("h", "m", "sex"), BODIES, ids=IDS)
def test_the_toes_are_their_share_of_the_foot_in_front_of_the_metatarsal_heads(h, m, sex):
    p = hm.BodyParameters(h, m, sex, toes=True)
    foot, d = segments(p)["foot"], body_dimensions(p)
    _, model = _models(h, m, sex)
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    for side in SIDES:
        toes = model.inertias[model.getJointId(f"{side}_mtp")]
        assert math.isclose(toes.mass, TOES["mass_fraction"] * foot.mass, rel_tol=1e-12)
        assert np.linalg.eigvalsh(model.inertias[model.getJointId(f"{side}_mtp")].inertia).min() > 0
        x = {
            k: data.oMf[model.getFrameId(f"{side}_{k}_inner")].translation
            for k in ("heel", "meta", "toe")
        }
        assert math.isclose(x["toe"][0] - x["heel"][0], foot.length, rel_tol=1e-12)
        assert math.isclose(
            x["meta"][0] - x["heel"][0], TOES["mtp_fraction"] * foot.length, rel_tol=1e-12
        )
        # every contact point on the sole plane, the foot's width apart
        for k in ("heel", "meta", "toe"):
            inner, outer = (
                data.oMf[model.getFrameId(f"{side}_{k}_{e}")].translation
                for e in ("inner", "outer")
            )
            assert abs(inner[2] - outer[2]) < 1e-12
            assert math.isclose(abs(inner[1] - outer[1]), d["foot_width"], rel_tol=1e-12)
        # the two sole frames are on the sole, each at the centre of its part
        for frame, (a, b) in (
            (f"{side}_sole", ("heel", "meta")),
            (f"{side}_toes_sole", ("meta", "toe")),
        ):
            centre = (x[a][0] + x[b][0]) / 2
            placed = data.oMf[model.getFrameId(frame)].translation
            assert math.isclose(placed[0], centre, abs_tol=1e-12), frame
            assert abs(placed[2] - x["heel"][2]) < 1e-12
        # the contact points ride on their part
        mtp = model.getJointId(f"{side}_mtp")
        for k, joint in (("heel", mtp - 1), ("meta", mtp), ("toe", mtp)):
            assert model.frames[model.getFrameId(f"{side}_{k}_outer")].parentJoint == joint, k


@pytest.mark.parametrize("side", SIDES)
def test_positive_mtp_is_dorsiflexion_about_the_metatarsal_heads(side):
    """+0.3 rad lifts the toe tip about the metatarsal heads; the heel and the rearfoot's sole
    stay where they were."""
    _, model = _models(1.75, 75.0, "male")
    data = model.createData()
    q0 = pin.neutral(model)
    q1 = q0.copy()
    q1[model.joints[model.getJointId(f"{side}_mtp")].idx_q] = 0.3

    def at(q, name):
        pin.framesForwardKinematics(model, data, q)
        return data.oMf[model.getFrameId(name)].translation.copy()

    assert at(q1, f"{side}_toe_outer")[2] - at(q0, f"{side}_toe_outer")[2] > 0.01
    # the metatarsal-head points turn about the axis joint_z above them: forward and up
    moved = at(q1, f"{side}_meta_inner") - at(q0, f"{side}_meta_inner")
    r = (
        TOES["height_fraction"]
        * body_dimensions(hm.BodyParameters(1.75, 75.0, "male"))["ankle_height"]
        / 2
    )
    np.testing.assert_allclose(moved, [r * math.sin(0.3), 0.0, r * (1 - math.cos(0.3))], atol=1e-12)
    for still in (f"{side}_heel_outer", f"{side}_sole"):
        np.testing.assert_allclose(at(q1, still), at(q0, still), atol=1e-15)


def test_mtp_range_damping_and_stiffness_are_tabulated_and_scaled():
    for key in ("mtp",):
        assert JOINT_RANGES[key].source and PASSIVE_JOINTS[key].source
    rng = JOINT_RANGES["mtp"]
    for mass in (45.0, 100.0):
        _, model = _models(1.75, mass, "male")
        for side in SIDES:
            j = model.joints[model.getJointId(f"{side}_mtp")]
            assert math.isclose(model.lowerPositionLimit[j.idx_q], math.radians(rng.lower))
            assert math.isclose(model.upperPositionLimit[j.idx_q], math.radians(rng.upper))
            assert math.isclose(model.damping[j.idx_v], PASSIVE_JOINTS["mtp"].damping * mass / 75)


def test_the_loader_takes_the_rearfoot_sole_as_the_foot():
    h = hm.load(hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male", toes=True)))
    assert h.feet == ("left_sole", "right_sole")
    assert (h.nq, h.nv) == (49, 41)
    # its standing pose puts every sole contact point on the floor
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, h.standing_configuration())
    for side in SIDES:
        for k in ("heel", "meta", "toe"):
            for e in ("inner", "outer"):
                z = data.oMf[h.model.getFrameId(f"{side}_{k}_{e}")].translation[2]
                assert abs(z) < 1e-12


def test_toes_must_be_a_boolean():
    with pytest.raises(BodyParameterError, match="toes must be True or False"):
        hm.BodyParameters(1.75, 75.0, "male", toes="yes")


def test_build_toes_from_the_command_line(tmp_path, capsys):
    from humanoid.cli import main

    out = tmp_path / "t.urdf"
    assert (
        main(
            ["build", "--height", "1.7", "--mass", "70", "--sex", "male", "--toes", "-o", str(out)]
        )
        == 0
    )
    assert "toes" in capsys.readouterr().out
    assert "left_mtp" in out.read_text() and "toes" in out.read_text().splitlines()[1]


def test_opensim_mtp_angle_goes_to_the_toes_and_is_left_out_with_a_warning_without():
    """gait2392's mtp_angle_r/_l: written from and read back into a toes body's *_mtp; a body
    with a one-piece foot leaves the columns out and says so."""
    from humanoid.motion.coordinates import MAPS, UnmappedWarning, configurations, coordinates_table

    toes = hm.load(hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male", toes=True)))
    q = np.tile(toes.standing_configuration(), (3, 1))
    for side, angles in (("left", [0.1, 0.2, 0.3]), ("right", [-0.2, 0.0, 0.4])):
        q[:, toes.model.joints[toes.model.getJointId(f"{side}_mtp")].idx_q] = angles
    table = coordinates_table(toes, np.arange(3) * 0.01, q, "gait2392")
    k = table.labels.index("mtp_angle_l")
    np.testing.assert_allclose(np.radians(table.data[:, k]), [0.1, 0.2, 0.3], atol=1e-12)
    _, back, unmapped = configurations(toes, table, MAPS["gait2392"], floor=False)
    np.testing.assert_allclose(back, q, atol=1e-12)
    assert unmapped == []
    plain = hm.load(hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male", toes=False)))
    with pytest.warns(UnmappedWarning, match="mtp_angle_r, mtp_angle_l"):
        _, _, unmapped = configurations(plain, table, MAPS["gait2392"], floor=False)
    assert unmapped == ["mtp_angle_r", "mtp_angle_l"]


def test_the_feet_ground_contact_includes_the_toes():
    """A scene's ``ground.bodies = "feet"`` is each foot and what hangs below it: the toes'
    geometry touches the floor too."""
    from humanoid.scene import Effects, GroundSpec, Scene
    from humanoid.simulation import Simulation

    h = hm.load(hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male", toes=True)))
    scene = Scene(name="toes", body=h.source, ball_joints=h.ball_joints, duration=0.01,
                  integrator="semi_implicit_euler",
                  effects=Effects(ground=GroundSpec(bodies="feet")))  # fmt: skip
    sim = Simulation(scene, humanoid=h)
    model = sim.model
    joints = set(sim.ground.ground.joints.tolist())
    names = {model.names[j] for j in joints}
    assert {"left_mtp", "right_mtp"} <= names
    assert {model.names[model.frames[h.sole_id(s)].parentJoint] for s in SIDES} <= names


def test_a_body_with_its_toes_locked_is_the_one_piece_foot_body():
    """``lock_foot_hinges``: the MTP hinges locked at zero, the two boxes one: the mass matrix
    of the body with one-piece feet (to 1e-12), its sole box, and a recipe that loads it again;
    the toes' frames are kept; a body without foot hinges is returned as it is."""
    from humanoid.model import load_recipe, lock_foot_hinges, restrict_configurations

    toes = hm.load(hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male", toes=True)))
    plain = hm.load(hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male", toes=False)))
    locked = lock_foot_hinges(toes)
    assert (locked.nq, locked.nv) == (plain.nq, plain.nv) == (47, 39)
    q = plain.standing_configuration()
    M = pin.crba(locked.model, locked.model.createData(), q)
    np.testing.assert_allclose(M, pin.crba(plain.model, plain.model.createData(), q), atol=1e-12)
    assert locked.model.existFrame("left_toe_inner") and locked.recipe["lock"] == [
        "left_mtp", "right_mtp"]  # fmt: skip

    def boxes(h, side):
        j = h.model.frames[h.sole_id(side)].parentJoint
        return [(g.placement.translation.round(12).tolist(), list(g.geometry.halfSide))
                for g in h.collision_model.geometryObjects if g.parentJoint == j]  # fmt: skip

    for side in SIDES:
        assert boxes(locked, side) == boxes(plain, side)
    again = load_recipe(locked.recipe)  # (as a saved run reloads it: the same boxes)
    assert again.nq == 47 and all(boxes(again, side) == boxes(plain, side) for side in SIDES)
    with pytest.raises(hm.ModelError, match="cannot lock 'tail': the body has no joint"):
        hm.load("adult_male", lock=["tail"])
    with pytest.raises(hm.ModelError, match="cannot lock 'root_joint': only hinges"):
        hm.load("adult_male", lock="root_joint")
    assert lock_foot_hinges(plain) is plain
    # configurations of the body with toes, on the locked one: the toes' angles dropped
    qt = np.tile(toes.standing_configuration(), (2, 1))
    qt[:, 7] = [0.1, 0.2]  # the left hip's quaternion's x
    np.testing.assert_array_equal(restrict_configurations(qt, toes, locked)[:, :8], qt[:, :8])


def test_a_welded_foot_locks_its_toes_and_the_lock_is_internal():
    """A weld on a foot with toes holds the rearfoot's sole and locks the MTP hinge: under
    gravity, standing on both welded feet, the toes do not move (their hinge has no torque)
    and the welds carry the body's weight (the locks' torques are internal)."""
    from humanoid.constraints import JointLock
    from humanoid.scene import Contact, Effects, Scene

    h = hm.load("adult_male")
    feet = tuple(Contact(s, "weld") for s in SIDES)
    scene = Scene(name="welded", body="adult_male", duration=0.2, dt=1e-3, record_rate=1000.0,
                  integrator="semi_implicit_euler", effects=Effects(contacts=feet))  # fmt: skip
    traj = hm.simulate(scene, quiet=True)
    assert traj.status == "completed"
    for side in SIDES:
        j = h.model.joints[h.model.getJointId(f"{side}_mtp")]
        assert np.abs(traj.q[:, j.idx_q]).max() < 1e-9
        assert np.abs(traj.forces["foot_locks"][5:, j.idx_v]).max() > 0.0  # the lock holds
    # the welds carry the weight (at the start, at rest, the joints just giving way: measured
    # 0.03 % under it)
    fz = traj.forces["left"][0, 2] + traj.forces["right"][0, 2]
    assert fz == pytest.approx(h.mass * 9.81, rel=1e-3)
    with pytest.raises(hm.ModelError, match="one-degree-of-freedom"):
        JointLock("x", h.model, h.model.getJointId("left_hip"), 0.0)
