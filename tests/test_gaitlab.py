"""Gait-lab angles of any humanoid, and the normative data the walk and its report use."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import humanoid as hm
from humanoid.errors import WalkError
from humanoid.walking import clinical
from humanoid.walking.clinical import ANGLES, LegChain, arm_chains, clinical_angles, leg_chains
from humanoid.walking.norms import ADULT, choose_gait, free_speed, norms


@pytest.fixture(scope="module")
def euler_body():
    return hm.load("adult_male", ball_joints="euler")


@pytest.mark.parametrize(
    "joint, angle",
    [("hip_flexion", "hip_flexion"), ("hip_adduction", "hip_adduction"),
     ("hip_rotation", "hip_rotation"), ("knee", "knee_flexion"),
     ("ankle_flexion", "ankle_dorsiflexion")],
)  # fmt: skip
@pytest.mark.parametrize("side", ["left", "right"])
def test_one_hinge_reads_as_its_clinical_angle(euler_body, side, joint, angle):
    """A hinge of our URDF moved alone reads as its clinical angle, with the clinic's sign
    (our URDF's hinges are flexion, adduction, internal rotation, knee flexion, dorsiflexion),
    and every other angle stays zero."""
    m = euler_body.model
    q = euler_body.standing_configuration()
    q[m.joints[m.getJointId(f"{side}_{joint}")].idx_q] = 0.3
    a = clinical_angles(euler_body, q)
    expected = np.zeros(len(ANGLES))
    expected[ANGLES.index(angle)] = math.degrees(0.3)
    np.testing.assert_allclose(a[side], expected, atol=1e-9)
    other = "left" if side == "right" else "right"
    np.testing.assert_allclose(a[other], 0.0, atol=1e-9)


def test_pelvis_angles_against_the_room(euler_body):
    """Tilting, rolling and turning the whole standing body: only the pelvis angles move, with
    the side's own sign (its hip up, its hip forward)."""
    q0 = euler_body.standing_configuration()
    for axis, k, signs in (("y", 0, (1, 1)), ("x", 1, (1, -1)), ("z", 2, (-1, 1))):
        q = q0.copy()
        q[3:7] = pin.Quaternion(pin.utils.rotate(axis, 0.1)).coeffs()
        a = clinical_angles(euler_body, q)
        for side, sign in zip(("left", "right"), signs, strict=True):
            expected = np.zeros(len(ANGLES))
            expected[k] = sign * math.degrees(0.1)
            np.testing.assert_allclose(a[side], expected, atol=1e-9)


def test_ball_joints_read_like_their_hinges(euler_body):
    """The quaternion body's angles equal its Euler twin's on random postures: the angles come
    from the segments, not from the joint coordinates."""
    h = hm.load("adult_male")
    rng = np.random.default_rng(3)
    m = euler_body.model
    qe = np.tile(euler_body.standing_configuration(), (20, 1))
    lo, hi = m.lowerPositionLimit[7:], m.upperPositionLimit[7:]
    qe[:, 7:] = rng.uniform(lo, hi, (20, m.nq - 7)) * 0.5
    qe[:, 3:7] = [pin.Quaternion(pin.exp3(rng.normal(0, 0.2, 3))).coeffs() for _ in range(20)]
    q, _ = h.from_euler(qe)
    a, b = clinical_angles(euler_body, qe), clinical_angles(h, q)
    for side in ("left", "right"):
        np.testing.assert_allclose(a[side], b[side], atol=1e-9)


def test_a_robots_knee_is_found():
    talos = hm.load("talos")
    assert talos.model.names[LegChain(talos, "left").knee] == "leg_left_4_joint"
    assert talos.model.names[LegChain(talos, "right").knee] == "leg_right_4_joint"


@pytest.mark.parametrize(
    "name, shoulder, elbow",
    [("adult_male", "right_shoulder", "right_elbow"),
     ("talos", "arm_right_2_joint", "arm_right_4_joint"),
     ("g1", "right_shoulder_pitch_joint", "right_elbow_joint"),
     ("human", "right_shoulder", "right_elbow_Z")],
)  # fmt: skip
def test_the_arms_are_found_and_their_swing_reads_as_shoulder_flexion(name, shoulder, elbow):
    """Each model's right arm: its shoulder and elbow found from the tree; zero standing; the
    whole arm turned forward about the trunk's lateral axis by 0.3 rad (rotating the upper arm
    and everything below it) reads as 0.3 rad of shoulder flexion and no elbow flexion."""
    h = hm.load(name)
    m = h.model
    arm = arm_chains(h)["right"]
    assert (m.names[arm.shoulder], m.names[arm.elbow]) == (shoulder, elbow)
    d = m.createData()
    pin.framesForwardKinematics(m, d, h.standing_configuration())
    np.testing.assert_allclose(arm.angles(d), 0.0, atol=1e-9)
    # rotate the shoulder-to-hand points about the shoulder's centre (the trunk is upright)
    turn = pin.utils.rotate("y", -0.3)  # forward: the hanging arm's end moves to +x
    s = d.oMi[arm.shoulder].translation.copy()
    for j in (arm.elbow, arm.hand):
        d.oMi[j].translation = s + turn @ (d.oMi[j].translation - s)
    np.testing.assert_allclose(arm.angles(d), [math.degrees(0.3), 0.0], atol=1e-9)


@pytest.mark.parametrize(
    "name, torso",
    [("adult_male", "thorax"), ("human", "middle_thorax"), ("talos", "torso_2_link"),
     ("g1", "waist_pitch_joint")],
)  # fmt: skip
def test_the_trunk_is_found_by_name_or_from_where_the_arms_hang(name, torso):
    """The torso frame the walk keeps upright: by name where the model has one, else (the g1:
    no torso name known) the frame of the joint both arms hang from, its waist. Without it the
    g1's whole upper body hung on a 3e-3 posture weight and its walk fell within 2-3 s."""
    h = hm.load(name)
    m = h.model
    f = clinical.torso_frame(m, arm_chains(h).values())
    assert m.frames[f].name == torso
    assert clinical.torso_frame(m) is None if name == "g1" else clinical.torso_frame(m) == f


def test_a_body_without_arms_has_no_arm_chains(tmp_path):
    """A humanoid whose trunk has nothing beside it: no arm chains, not an error."""
    h = hm.load("adult_male")
    legs = leg_chains(h)
    arms = arm_chains(h, legs)
    assert set(arms) == {"left", "right"}
    # the same search on a model whose arms are cut off at the shoulder finds nothing
    urdf = hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male"))
    import xml.etree.ElementTree as ET

    root = ET.fromstring(urdf.split("\n", 1)[1])
    drop = {"upper_arm", "elbow", "forearm", "wrist", "hand", "shoulder"}
    for el in list(root):
        name = el.get("name", "")
        if any(k in name for k in drop):
            root.remove(el)
    path = tmp_path / "no_arms.urdf"
    path.write_text(ET.tostring(root, encoding="unicode"))
    assert arm_chains(hm.load(path)) == {}


def test_the_normative_curves():
    """Schwartz 2008 as published: at free speed the knee flexes to 59 deg in swing, the
    vertical force peaks at 1.10 BW, the plantarflexor moment at 1.23 N m/kg; a class's own
    speed gives its own curve; the events sum up (double support = 2 x opposite foot off)."""
    n = norms()
    free = n.class_speeds[2]
    knee, sd = n.curve("knee_flexion", free)
    assert len(knee) == len(n.percent) == 51 and np.all(sd > 0)
    assert abs(knee.max() - 59.13) < 0.05
    assert abs(n.curve("grf_vertical", free)[0].max() - 1.10) < 0.01
    assert abs(n.curve("ankle_plantarflexion_moment", free)[0].max() - 1.23) < 0.01
    assert n.units["ankle_power"] == "W/kg" and n.units["grf_vertical"] == "BW"
    fast = n.curve("knee_flexion", n.class_speeds[3])[0]
    halfway = n.curve("knee_flexion", (n.class_speeds[2] + n.class_speeds[3]) / 2)[0]
    np.testing.assert_allclose(halfway, (knee + fast) / 2, atol=1e-9)
    assert abs(n.scalar("double_support", free) - 2 * n.scalar("opposite_foot_off", free)) < 0.02
    with pytest.raises(WalkError, match="no normative curve"):
        n.curve("elbow", free)


@pytest.mark.parametrize("leg", [0.78, 0.84, 0.91, 1.01])
def test_a_person_chooses_step_length_and_cadence_together(leg):
    """At the free speed of any adult leg, speed, cadence and step length land in the adult
    norms, and step length x cadence is the speed; faster walking lengthens and quickens."""
    v = free_speed(leg)
    g = choose_gait(v, leg)
    assert ADULT["speed"][0][0] - 0.05 <= v <= ADULT["speed"][0][1]
    assert 100 <= g["cadence"] <= 120 and 0.62 <= g["step_length"] <= 0.80
    assert abs(g["step_length"] * g["cadence"] / 60 - v) < 1e-12
    assert 0.18 <= g["double_support"] <= 0.26
    slow, fast = choose_gait(0.8, leg), choose_gait(1.6, leg)
    assert slow["step_length"] < g["step_length"] < fast["step_length"]
    assert slow["cadence"] < g["cadence"] < fast["cadence"]


def test_the_norms_on_a_level_pelvis_keep_the_thigh_against_the_room():
    """Schwartz's pelvis (the iliac spines' plane) tilts forward; on the body's level pelvis
    the tilt and the hip flexion (thigh against pelvis) lose the mean tilt, and nothing else
    moves."""
    n = norms()
    v = 0.46
    tilt = n.mean_tilt(v)
    assert 8.0 < tilt < 16.0, tilt
    for name in ("pelvis_tilt", "hip_flexion"):
        lab, sd = n.curve(name, v)
        level, sd_level = n.curve(name, v, pelvis="level")
        np.testing.assert_allclose(level, lab - tilt)
        np.testing.assert_array_equal(sd_level, sd)
    assert abs(n.curve("pelvis_tilt", v, pelvis="level")[0][:-1].mean()) < 1e-12
    # the thigh's angle to the room: hip flexion less the tilt, the same on both pelvises
    thigh = n.curve("hip_flexion", v)[0] - n.curve("pelvis_tilt", v)[0]
    level = n.curve("hip_flexion", v, "level")[0] - n.curve("pelvis_tilt", v, "level")[0]
    np.testing.assert_allclose(thigh, level)
    np.testing.assert_array_equal(n.curve("knee_flexion", v, "level")[0],
                                  n.curve("knee_flexion", v)[0])  # fmt: skip
    with pytest.raises(WalkError, match="pelvis"):
        n.curve("hip_flexion", v, pelvis="tilted")


def test_a_force_plates_filter_keeps_gait_and_removes_ticks():
    """The zero-lag low-pass at 15 Hz: a 2 Hz wave (the gait's own content) through unchanged
    in amplitude and phase; 1 kHz ticks (the simulation's contact impulses) gone."""
    from humanoid.walking.gait import CUTOFF, low_pass

    t = np.arange(0.0, 3.0, 1e-3)
    slow = np.sin(2 * np.pi * 2.0 * t)
    ticks = 0.5 * (-1.0) ** np.arange(len(t))
    out = low_pass(np.column_stack([slow + ticks, slow]), t)
    inner = slice(200, -200)
    np.testing.assert_allclose(out[inner, 0], slow[inner], atol=2e-3)
    np.testing.assert_allclose(out[inner, 1], slow[inner], atol=2e-3)
    # at the cut-off, the forward-backward second order passes half the amplitude
    at_cutoff = low_pass(np.sin(2 * np.pi * CUTOFF * t), t)
    assert 0.45 < np.abs(at_cutoff[inner]).max() < 0.55


def test_events_need_the_force_to_fall_below_the_lower_threshold():
    """A force chattering about the upper threshold (2 % BW) after it first crossed it stays
    one contact: hysteresis, as a force plate's event detection."""
    from humanoid.walking.gait import EVENT_OFF, EVENT_ON, hysteresis

    weight = 700.0
    on, off = EVENT_ON * weight, EVENT_OFF * weight
    x = np.array([0, 5, on + 1, on - 1, on + 1, off + 1, on - 1, off - 1, off + 1, on + 1, 0.0])
    np.testing.assert_array_equal(hysteresis(x, on, off),
                                  [0, 0, 1, 1, 1, 1, 1, 0, 0, 1, 0])  # fmt: skip


def _analysis_of(curves: dict, v_hat: float = 0.46):
    from humanoid.walking.gait import GaitAnalysis

    both = {s: {n: np.atleast_2d(c) for n, c in curves.items()} for s in ("left", "right")}
    return GaitAnalysis({}, {}, both, {}, {"left": [], "right": []}, v_hat, 75.0)


def test_a_curve_in_band_and_its_roughness():
    """in_band: the share of the cycle inside the norm's mean +- 2 SD on the body's level
    pelvis (the lab pelvis's hip flexion, 12 deg higher, is partly outside); roughness: the
    norm itself is 1, a 1 N m/kg one-sample spike adds nearly 2 N m/kg of variation."""
    n = norms()
    v = 0.46
    hip_level = n.curve("hip_flexion", v, pelvis="level")[0]
    hip_lab = n.curve("hip_flexion", v)[0]
    moment = n.curve("knee_extension_moment", v)[0]
    spiked = moment.copy()
    spiked[30] += 1.0
    a = _analysis_of({"hip_flexion": hip_level, "knee_extension_moment": moment})
    assert a.in_band("hip_flexion") == 1.0
    assert math.isclose(a.roughness("knee_extension_moment"), 1.0)
    b = _analysis_of({"hip_flexion": hip_lab, "knee_extension_moment": spiked})
    assert b.in_band("hip_flexion") < 0.9
    variation = np.abs(np.diff(moment)).sum()  # 2.5 N m/kg
    assert b.roughness("knee_extension_moment") > (variation + 1.8) / variation


def test_in_band_is_as_wide_as_it_is_asked():
    """in_band(sds): the norm's mean + 1.5 SD is inside +- 2 SD and outside +- 1 SD (a
    planted width of 1 SD whatever ``sds`` says passed the test above)."""
    n = norms()
    v = 0.46
    mean, sd = n.curve("knee_extension_moment", v, pelvis="level")
    assert sd.min() > 0
    a = _analysis_of({"knee_extension_moment": mean + 1.5 * sd})
    assert a.in_band("knee_extension_moment") == 1.0
    assert a.in_band("knee_extension_moment", sds=1.0) == 0.0
    assert a.in_band("knee_extension_moment", sds=1.4) == 0.0
    assert a.in_band("knee_extension_moment", sds=1.6) == 1.0
