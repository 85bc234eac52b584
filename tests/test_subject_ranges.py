"""A subject's own ranges of motion: ``BodyParameters(ranges=...)``, ``--range JOINT=LO,HI``.

The body's ranges are clinical normals (:data:`humanoid.body.JOINT_RANGES`: the ankle's
dorsiflexion 20 deg). A person's may differ (a contracture, a crouch gait's dorsiflexion past
20 deg): the body is built with theirs, the URDF says them, scaling keeps them, and a generated
crouch gait that the normal ankle cannot follow is tracked once the body has the range."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pinocchio as pin
import pytest

import humanoid as hm
from humanoid.anthropometry import BodyParameters
from humanoid.body import JOINT_RANGES
from humanoid.errors import BodyParameterError, ScalingError

CROUCH = {"ankle_flexion": (-50.0, 30.0)}


def _limits(h, joint: str) -> tuple[float, float]:
    m = h.model
    i = m.joints[m.getJointId(joint)].idx_q
    return math.degrees(m.lowerPositionLimit[i]), math.degrees(m.upperPositionLimit[i])


def test_a_subjects_ranges_replace_the_normals_where_given():
    """By kind on both sides, by joint on one; the rest keep the normals; the URDF's comment
    says them and reads back as the same parameters."""
    from humanoid.motion.scale import body_parameters_of

    p = BodyParameters(1.75, 75.0, "male", ranges={**CROUCH, "right_knee": (5, 120)})
    h = hm.load(hm.build_urdf(p))
    assert _limits(h, "left_ankle_flexion") == pytest.approx((-50.0, 30.0))
    assert _limits(h, "right_ankle_flexion") == pytest.approx((-50.0, 30.0))
    assert _limits(h, "right_knee") == pytest.approx((5.0, 120.0))
    normal = JOINT_RANGES["knee"]
    assert _limits(h, "left_knee") == pytest.approx((normal.lower, normal.upper))
    plain = hm.load(hm.build_urdf(BodyParameters(1.75, 75.0, "male")))
    assert _limits(plain, "right_ankle_flexion") == pytest.approx((-50.0, 20.0))
    back = body_parameters_of(h)
    assert back == p and dict(back.ranges) == {**CROUCH, "right_knee": (5.0, 120.0)}
    assert hash(back) == hash(p) != hash(BodyParameters(1.75, 75.0, "male"))
    # a ball joint's hinge (the hip's ab/adduction) keeps its range through the fusion
    ball = hm.load(hm.build_urdf(BodyParameters(1.75, 75.0, "male",
                                                ranges={"hip_adduction": (-20, 10)})))  # fmt: skip
    em = ball.fusion.euler_model
    i = em.joints[em.getJointId("left_hip_adduction")].idx_q
    assert math.degrees(em.lowerPositionLimit[i]) == pytest.approx(-20.0)
    assert math.degrees(em.upperPositionLimit[i]) == pytest.approx(10.0)


@pytest.mark.parametrize(("ranges", "said"), [
    ({"ankle": (-50, 30)}, "unknown joint range 'ankle'"),
    ({"left_lumbar_flexion": (-10, 40)}, "unknown joint range 'left_lumbar_flexion'"),
    ({"ankle_flexion": (30, -50)}, "lower bound 30 deg must be below the upper -50"),
    ({"ankle_flexion": 30}, r"ranges\['ankle_flexion'\] must be \(lower, upper\)"),
    ({"ankle_flexion": (-50, float("nan"))}, r"ranges\['ankle_flexion'\] upper must be in"),
    ({"knee": (0, 200)}, r"ranges\['knee'\] upper must be in \[-180.0, 180.0\] deg"),
    ({"knee": ("0", 120)}, r"ranges\['knee'\] lower must be a number"),
    ([("knee", 0, 1)], "ranges must be a mapping"),
])  # fmt: skip
def test_a_bad_range_is_an_error_naming_it(ranges, said):
    with pytest.raises(BodyParameterError, match=said):
        BodyParameters(1.75, 75.0, "male", ranges=ranges)


def test_with_ranges_rebuilds_a_toolkit_body_and_refuses_another():
    """A toolkit body loaded with its options (ball joints, locked toes) comes back the same
    but for the ranges; a URDF that does not say its parameters is refused."""
    from humanoid.model import lock_foot_hinges
    from humanoid.motion.scale import with_ranges

    h = lock_foot_hinges(hm.load("adult_male"))
    w = with_ranges(h, CROUCH)
    assert (w.nq, w.model.nv, w.mass) == (h.nq, h.model.nv, h.mass)
    assert _limits(w, "right_ankle_flexion") == pytest.approx((-50.0, 30.0))
    assert _limits(w, "right_knee") == _limits(h, "right_knee")
    q = h.standing_configuration()
    assert np.allclose(pin.crba(w.model, w.model.createData(), q),
                       pin.crba(h.model, h.model.createData(), q))  # fmt: skip
    text = h.recipe["urdf"].replace("humanoid body:", "a body:")
    with pytest.raises(ScalingError, match="not one of the toolkit's bodies"):
        with_ranges(hm.load(text), CROUCH)


def test_scaling_keeps_the_bodys_ranges_and_adds_the_subjects():
    """A static trial (the standing body's markers) scaled onto a body with its own ankle
    range, a knee range given: the scaled URDF has both."""
    from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions
    from humanoid.motion.scale import scale_body

    p = BodyParameters(1.75, 75.0, "male", ranges=CROUCH)
    h = hm.load(hm.build_urdf(p))
    markers = default_markers(h)
    pos = marker_positions(h, np.tile(h.standing_configuration(), (5, 1)), markers)
    static = MarkerTrajectories(np.arange(5) * 0.01, list(markers), pos * 1.05)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = scale_body(h, static, None, 80.0, ranges={"right_knee": (5, 120)})
    assert dict(r.params.ranges) == {**CROUCH, "right_knee": (5.0, 120.0)}
    assert _limits(r.body, "left_ankle_flexion") == pytest.approx((-50.0, 30.0))
    assert _limits(r.body, "right_knee") == pytest.approx((5.0, 120.0))
    assert "range ankle_flexion -50.0 30.0 deg" in r.urdf


def test_cli_build_takes_ranges_and_refuses_a_malformed_one(tmp_path, capsys):
    from humanoid.cli import main

    out = tmp_path / "crouch.urdf"
    args = ["--range", "ankle_flexion=-50,30", "--range", "left_knee=10,130", "-o", str(out)]
    assert main(["build", "--height", "1.5", "--mass", "45", "--sex", "female", *args]) == 0
    said = capsys.readouterr().out
    assert "ankle_flexion -50 to 30 deg" in said and "left_knee 10 to 130 deg" in said
    h = hm.load(str(out))
    assert _limits(h, "right_ankle_flexion") == pytest.approx((-50.0, 30.0))
    assert _limits(h, "left_knee") == pytest.approx((10.0, 130.0))
    with pytest.raises(SystemExit) as e:
        main(["build", "--height", "1.5", "--mass", "45", "--sex", "female",
              "--range", "ankle_flexion=30", "-o", str(out)])  # fmt: skip
    assert e.value.code == 2
    assert "expected JOINT=LOWER,UPPER" in capsys.readouterr().err


def _crouched(h, t, q, drop: float):
    """Markers of the walk crouched: its pelvis, trunk, arms and head (and the hips' centres)
    ``drop`` lower, its feet where they were; the thighs' and shanks' markers left out, for
    the fit to bend the knees."""
    from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions

    markers = default_markers(h)
    foot = ("Heel", "Midfoot", "Toe", "toes", "ankle", "Ankle")
    feet = [n for n in markers if any(w in n for w in foot)]
    legs = ("Thigh", "Shank", "Knee", "knee")
    upper = [n for n in markers if n not in feet and not any(w in n for w in legs)]
    low = q.copy()
    low[:, 2] -= drop
    pos = np.concatenate([marker_positions(h, low, markers, upper),
                          marker_positions(h, q, markers, feet)], axis=1)  # fmt: skip
    return MarkerTrajectories(t, upper + feet, pos), markers


def test_a_crouch_gait_tracks_once_the_body_has_the_ankle_range(walk_1khz):
    """The walk crouched 5 cm (its knees bent 40 deg in stance, as a mild crouch gait): the
    normal ankle's 20 deg of dorsiflexion cannot keep the feet flat (inverse kinematics says it
    held the ankles there) and tracking loses the motion (measured: lost at 0.13 s, fell at
    0.76 s); with the subject's 35 deg the fit keeps the ankles inside (33 deg at most) and
    tracking follows it (measured: 0.42 deg RMS, the root within 7 mm, the peak vertical force
    1.5 BW)."""
    from humanoid.motion.ik import RangeLimitWarning, inverse_kinematics
    from humanoid.motion.scale import with_ranges
    from humanoid.motion.tracking import track

    h, tr = walk_1khz
    t, q = tr.t[::10], tr.q[::10]
    seen, markers = _crouched(h, t, q, 0.05)
    with pytest.warns(RangeLimitWarning, match=r"right_ankle_flexion held at its upper limit "
                      r"20.0 deg.*--range JOINT=LOWER,UPPER"):  # fmt: skip
        warnings.simplefilter("ignore", UserWarning)
        warnings.simplefilter("always", RangeLimitWarning)
        normal = inverse_kinematics(h, seen, markers)
    lost = track(h, t, normal.q)
    assert not lost.completed or np.abs(lost.joint_error[:, :3]).max() > 0.1
    w = with_ranges(h, {"ankle_flexion": (-50.0, 35.0)})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = inverse_kinematics(w, seen, markers)
    assert not any("ankle_flexion" in r.coordinate for r in fit.at_limit), [
        r.describe() for r in fit.at_limit
    ]
    knee = w.model.joints[w.model.getJointId("right_knee")].idx_q
    assert np.degrees(fit.q[:20, knee]).min() > 35.0  # (the walk's own: under 20)
    res = track(w, t, fit.q)
    assert res.completed, res.trajectory.metadata.get("message")
    assert np.degrees(np.sqrt(np.mean(res.joint_error[:, 6:] ** 2))) < 1.0
    assert np.abs(res.joint_error[:, :3]).max() < 0.02
    for side in ("left", "right"):
        assert res.trajectory.forces[f"ground_{side}"][:, 2].max() < 2.0 * w.mass * 9.81


def test_the_motion_commands_give_their_body_the_subjects_ranges(tmp_path):
    """``--range`` on ``ik``/``id``/``track``'s body: one built from --height/--mass/--sex, a
    toolkit body by --model, and a URDF that does not say its parameters refused by name."""
    import argparse

    from humanoid.errors import UsageError
    from humanoid.motion.commands import subject_body

    def args(**kw):
        base = {"height": None, "mass": None, "sex": None, "model": None, "ranges": []}
        return argparse.Namespace(**{**base, **kw})

    built, what = subject_body(args(height=1.6, mass=60.0, sex="female",
                                    ranges=[("ankle_flexion", (-50.0, 30.0))]))  # fmt: skip
    assert _limits(built, "left_ankle_flexion") == pytest.approx((-50.0, 30.0))
    assert "ankle_flexion -50 to 30 deg" in what
    shipped, _ = subject_body(args(model="adult_female", ranges=[("right_knee", (5.0, 120.0))]))
    assert _limits(shipped, "right_knee") == pytest.approx((5.0, 120.0))
    assert _limits(shipped, "left_knee") == pytest.approx((0.0, 140.0))
    other = tmp_path / "other.urdf"
    other.write_text(shipped.recipe["urdf"].replace("humanoid body:", "a body:"))
    with pytest.raises(UsageError, match="--range: .*other.urdf.*give its URDF the ranges"):
        subject_body(args(model=str(other), ranges=[("knee", (0.0, 120.0))]))


def test_a_runs_own_body_takes_the_subjects_ranges(tmp_path, walk_1khz):
    """``humanoid id RUN.npz --range ...``: the run's own body (its toes locked, as it walked)
    is rebuilt with the range, and says so."""
    import argparse

    from humanoid.motion.commands import read_motion

    _, tr = walk_1khz
    run = tr.save(tmp_path / "walk.npz")
    args = argparse.Namespace(motion=str(run), model=None, height=None, mass=None, sex=None,
                              ranges=[("ankle_flexion", (-50.0, 35.0))], loads=None,
                              loads_side=None, loads_xml=None, map=None)  # fmt: skip
    h, what, *_ = read_motion(args)
    assert h.nq == tr.q.shape[1] and "(the run's); ankle_flexion -50 to 35 deg" in what
    assert _limits(h, "left_ankle_flexion") == pytest.approx((-50.0, 35.0))
