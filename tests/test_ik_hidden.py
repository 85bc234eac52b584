"""Inverse kinematics says what it hid: joints held at their ranges' bounds, coordinates no
marker sees, and each marker's residual (humanoid.motion.ik)."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import humanoid as hm
from humanoid.constraints.limits import JointRanges
from humanoid.motion.ik import (
    RangeLimitWarning,
    UnconstrainedWarning,
    _ranges,
    inverse_kinematics,
)
from humanoid.motion.markers import Marker, MarkerTrajectories, default_markers, marker_positions


@pytest.fixture(scope="module")
def body():
    return hm.load("adult_male")


def _motion(h, n=30, amplitude=0.3, margin=0.05):
    """``n`` configurations at 50 Hz swinging every joint about standing, kept ``margin``
    [rad] inside every range (a ball joint's: each of the hinge angles it replaces)."""
    model = h.model
    standing = h.standing_configuration()
    balls = JointRanges(h)
    t = np.arange(n) * 0.02
    qs = []
    for ti in t:
        v = np.zeros(model.nv)
        v[6:] = amplitude * np.sin(2 * np.pi * ti + np.arange(model.nv - 6))
        q = pin.integrate(model, standing, v)
        for _, iq, lo, hi in _ranges(model):
            q[iq] = np.clip(q[iq], lo + margin, hi - margin)
        angles = balls.angles(q, remember=False)
        for (ball, iq, _, lo, hi), th in zip(balls.balls, angles, strict=True):
            R = ball.rotation(np.clip(th, lo + margin, hi - margin))
            q[iq : iq + 4] = pin.Quaternion(R).coeffs()
        qs.append(q)
    return t, np.array(qs)


def _fit(h, t, qs, markers, noise=None, **kw):
    """The fit of the markers ``qs`` put them at (plus ``noise``, (n, m, 3)), and the warnings
    it gave."""
    pos = marker_positions(h, qs, markers)
    if noise is not None:
        pos = pos + noise
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = inverse_kinematics(h, MarkerTrajectories(t, list(markers), pos), markers, **kw)
    return r, [
        w for w in caught if issubclass(w.category, RangeLimitWarning | UnconstrainedWarning)
    ]


def _idx_q(h, joint):
    return h.model.joints[h.model.getJointId(joint)].idx_q


def test_a_joint_held_at_its_bound_is_reported(body):
    """The right ankle dorsiflexed to 5 degrees past its 20-degree bound over the trial's
    second half: the fit holds it at 20, the warning names it with its frames, and the markers
    wanted 5 degrees more (within 1); nothing else is reported."""
    h = body
    t, qs = _motion(h, n=20, amplitude=0.1)
    ankle = _idx_q(h, "right_ankle_flexion")
    hi = h.model.upperPositionLimit[ankle]
    qs[:, ankle] = hi + np.radians(np.linspace(-5.0, 5.0, len(t)))  # past it from frame 10 on
    r, said = _fit(h, t, qs, default_markers(h))
    past = qs[:, ankle] > hi + 1e-9
    np.testing.assert_allclose(r.q[past, ankle], hi, atol=1e-9)
    assert [x.coordinate for x in r.at_limit] == ["right_ankle_flexion"]
    report = r.at_limit[0]
    assert report.limit == "upper" and report.bound == pytest.approx(20.0)
    assert report.frames == past.sum()
    assert (report.start, report.end) == (t[past][0], t[past][-1])
    assert report.excess == pytest.approx(5.0, abs=1.0)
    ranged = [w for w in said if w.category is RangeLimitWarning]
    assert len(ranged) == 1
    text = str(ranged[0].message)
    assert "right_ankle_flexion held at its upper limit 20.0 deg" in text
    assert f"in {past.sum()} of {len(t)} frames" in text and "wanted up to 25.0 deg" in text


def test_a_ball_joint_held_at_its_bound_is_reported(body):
    """The trunk's thoracic ball joint flexed to 5 degrees past its 45-degree bound over the
    trial's second half: the fit with ``ball_ranges`` holds the flexion at 45, the report
    names the hinge it replaces with its frames, and the markers wanted 5 degrees more (within
    1); without, the fit follows the markers past the bound."""
    h = body
    t, qs = _motion(h, n=20, amplitude=0.05)
    balls = JointRanges(h)
    k = next(i for i, b in enumerate(balls.balls) if b[0].name.startswith("thoracic"))
    ball, iq, _, lo, hi = balls.balls[k]
    a = ball.hinges.index("thoracic_flexion")
    over = np.radians(np.linspace(-5.0, 5.0, len(t)))
    for q, extra in zip(qs, over, strict=True):
        th = balls.angles(q, remember=False)[k]
        th[a] = hi[a] + extra
        q[iq : iq + 4] = pin.Quaternion(ball.rotation(th)).coeffs()
    r, said = _fit(h, t, qs, default_markers(h), ball_ranges=True)
    past = over > 1e-9
    got = np.array([balls.angles(q, remember=False)[k, a] for q in r.q])
    np.testing.assert_allclose(got[past], hi[a], atol=2e-4)
    assert np.all(balls.excess(r.q[-1]) < 2e-4)
    report = next(x for x in r.at_limit if x.coordinate == "thoracic_flexion")
    assert report.limit == "upper" and report.bound == pytest.approx(np.degrees(hi[a]))
    assert report.frames >= past.sum() - 1
    assert report.excess == pytest.approx(5.0, abs=1.0)
    assert any("thoracic_flexion held at its upper limit" in str(w.message) for w in said)
    free, _ = _fit(h, t, qs, default_markers(h))
    past_free = np.array([balls.angles(q, remember=False)[k, a] for q in free.q])
    assert past_free[-1] > hi[a] + np.radians(4.0)


def test_a_motion_inside_its_ranges_warns_nothing(body):
    """Every marker, every joint inside its range: nothing held, nothing unseen, no warning."""
    h = body
    t, qs = _motion(h)
    r, said = _fit(h, t, qs, default_markers(h))
    assert said == [] and r.at_limit == [] and r.unconstrained == []


def test_a_segment_without_markers_is_named_and_held(body):
    """The right hand's markers removed: its wrist's two coordinates are named unseen, in every
    frame, and stay at standing while the data's wrist swings 15 degrees. A marker 3 mm from
    the wrist (as good as none) with 1 mm of noise: named too, and held (without the hold it
    swings 6.6 degrees: measured)."""
    h = body
    t, qs = _motion(h, n=30)
    standing = h.standing_configuration()
    wrist = ["right_wrist_flexion", "right_wrist_deviation"]
    iq = [_idx_q(h, n) for n in wrist]
    assert np.degrees(np.abs(qs[:, iq] - standing[iq]).max()) > 10.0
    markers = {n: m for n, m in default_markers(h).items() if m.frame != "right_hand"}
    r, said = _fit(h, t, qs, markers)
    assert r.unconstrained == wrist
    assert r.held[:, [r.coordinates.index(n) for n in wrist]].all()
    assert np.degrees(np.abs(r.q[:, iq] - standing[iq]).max()) < 0.1
    unseen = [w for w in said if w.category is UnconstrainedWarning]
    assert len(unseen) == 1 and all(f"{n} (30 of 30 frames)" in str(unseen[0].message)
                                    for n in wrist)  # fmt: skip
    # nearly unseen: what a marker barely off the axis says is noise
    markers["R.Hand.Near"] = Marker("right_wrist_deviation", (0.0, 0.003, 0.0), 1.0, True)
    noise = np.random.default_rng(1).normal(scale=0.001, size=(len(t), len(markers), 3))
    r, _ = _fit(h, t, qs, markers, noise)
    assert r.unconstrained == wrist
    assert np.degrees(np.abs(r.q[:, iq] - standing[iq]).max()) < 0.5


def test_each_markers_residual_is_kept(body):
    """2 cm of noise (per axis, seeded) on one marker only: its RMS residual is the largest,
    about the noise's (the others' below 1 cm), and its largest is larger still."""
    h = body
    t, qs = _motion(h, n=30)
    markers = default_markers(h)
    k = list(markers).index("R.Shank.Front")
    noise = np.zeros((len(t), len(markers), 3))
    noise[:, k] = np.random.default_rng(3).normal(scale=0.02, size=(len(t), 3))
    r, _ = _fit(h, t, qs, markers, noise)
    rms, top = r.marker_rms(), r.marker_max()
    assert max(rms, key=rms.get) == "R.Shank.Front"
    size = float(np.sqrt(np.mean(np.sum(noise[:, k] ** 2, axis=1))))  # the noise's RMS distance
    assert rms["R.Shank.Front"] == pytest.approx(size, rel=0.25)
    assert max(v for n, v in rms.items() if n != "R.Shank.Front") < 0.01
    assert top["R.Shank.Front"] >= rms["R.Shank.Front"]
    assert top["R.Shank.Front"] == pytest.approx(np.nanmax(r.residuals[:, k]))


def test_cli_ik_prints_what_it_hid(tmp_path, body, capsys):
    """``humanoid ik`` prints the worst markers' RMS and largest residuals, the joints held at
    their bounds and the unseen coordinates, one line each."""
    from humanoid.cli import main
    from humanoid.motion.markers import write_trc

    h = body
    t, qs = _motion(h, n=10, amplitude=0.1)
    ankle = _idx_q(h, "right_ankle_flexion")
    qs[:, ankle] = h.model.upperPositionLimit[ankle] + np.radians(5.0)
    markers = {n: m for n, m in default_markers(h).items() if m.frame != "right_hand"}
    seen = MarkerTrajectories(t, list(markers), marker_positions(h, qs, markers))
    write_trc(tmp_path / "m.trc", seen)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RangeLimitWarning)  # (printed, not warned)
        warnings.simplefilter("error", UnconstrainedWarning)
        args = ["ik", str(tmp_path / "m.trc"), "--model", "adult_male",
                "-o", str(tmp_path / "ik.mot"), "--quiet"]  # fmt: skip
        assert main(args) == 0
    text = capsys.readouterr().out
    assert "worst        " in text and " mm, max " in text
    held = "at limit     right_ankle_flexion held at its upper limit 20.0 deg in 10 of 10 frames"
    assert held in text
    assert "unseen       right_wrist_flexion in 10 of 10 frames, held" in text
    assert "unseen       right_wrist_deviation in 10 of 10 frames, held" in text
