"""Residual reduction (humanoid/motion/reduce.py): a motion and a body's mass properties
changed a little so that the pelvis residuals of its inverse dynamics vanish, as OpenSim's RRA
does."""

from __future__ import annotations

import copy
import math

import numpy as np
import pinocchio as pin
import pytest

from humanoid.errors import HumanoidError
from humanoid.motion.inverse_dynamics import derivatives, estimate_loads, inverse_dynamics
from humanoid.motion.loads import Load
from humanoid.motion.reduce import _with_mass, reduce_residuals, trunk_joint


@pytest.fixture(scope="module")
def walk(walk_1khz):
    """The simulated walk at 100 Hz with its own ground forces (consistent: small residuals)."""
    h, tr = walk_1khz
    t, q = tr.t[::10], tr.q[::10]
    loads = [Load.from_wrench(s, tr.t, tr.forces[f"ground_{s}"]) for s in ("left", "right")]
    return h, t, q, loads


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(x**2, axis=1))))


def _wobbled(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The pelvis moved forward and sideways by 8 mm at 1.3 Hz (a marker cluster's wobble): its
    acceleration is 0.5 m/s^2, which no ground force in the trial explains."""
    q = q.copy()
    q[:, 0] += 0.008 * np.sin(2 * np.pi * 1.3 * (t - t[0]))
    q[:, 1] += 0.008 * np.sin(2 * np.pi * 1.3 * (t - t[0]) + 1.0)
    return q


def test_a_wobbling_pelvis_is_taken_back_out(walk):
    """The wobble makes a residual force of about 7 % BW; the reduction (the measured loads:
    mass adjusted too) takes it under 1 % and the moment under a fifth, and the change it
    makes to the pelvis is the wobble taken back (its pelvis within 2 mm RMS of the clean
    walk's reduced, 5.7 mm before, up to a drift: residuals tell accelerations, not where a
    trajectory starts or how fast), the joints' changes under 1 deg RMS."""
    h, t, q, loads = walk
    W = h.mass * 9.81
    moved = _wobbled(t, q)
    r = reduce_residuals(h, t, moved, loads)
    before, after = r.force_rms(False), r.force_rms()
    print(*r.summary(), sep="\n")
    assert before > 0.04 * W
    assert after < 0.01 * W
    assert r.moment_rms() < 0.2 * r.moment_rms(False)
    assert r.mass == pytest.approx(h.mass, rel=0.02)
    clean = reduce_residuals(h, t, q, loads)  # (the walk's own small residuals reduced)
    print("clean walk:", *clean.summary(), sep="\n")
    back = np.array([pin.difference(h.model, a, b) for a, b in zip(r.q, clean.q, strict=True)])
    inner = slice(10, -10)  # (the filter's ends)
    ti = r.time[inner]
    basis = np.stack([np.ones_like(ti), ti], axis=1)
    left = back[inner, :2] - basis @ np.linalg.lstsq(basis, back[inner, :2], rcond=None)[0]
    assert np.sqrt(np.mean(left**2)) < 2e-3
    root = h.model.names[1]
    assert all(math.degrees(v) < 1.0 for k, v in r.change.items() if not k.startswith(root))
    # the reduced motion's own inverse dynamics, on the body with the changed mass, has the
    # residual the reduction reports
    body = copy.copy(h)
    body.model = r.model
    check = inverse_dynamics(body, r.time, r.q, r.loads, cutoff=None)
    assert _rms(check.residual_force) == pytest.approx(after, rel=0.05, abs=0.5)


def test_a_misplaced_trunk_mass_centre_is_found(walk):
    """The body inverse dynamics runs on has its upper trunk's mass centre 4 cm behind and 2 cm
    to the left of the body that walked: step 1 moves it back within 1.5 cm (measured: 40.6 mm
    forward and 29.1 to the right, the filtered impacts' own residual in the mean; 30.5 in a
    worker whose walk took other rounding), and the residual moment falls by more than half
    before any kinematic change."""
    h, t, q, loads = walk
    j = trunk_joint(h.model)
    assert h.model.names[j] == "thoracic"
    wrong = copy.copy(h)
    wrong.model = _with_mass(h.model, j, 1.0, np.array([-0.04, 0.02, 0.0]))
    r = reduce_residuals(wrong, t, q, loads, iterations=1)
    np.testing.assert_allclose(r.com_shift[:2], [0.04, -0.02], atol=0.015)
    assert r.trunk == "thoracic"
    assert r.moment_rms() < 0.5 * r.moment_rms(False)


def test_estimated_loads_keep_the_mass(walk):
    """With estimated loads (fitted to the body's mass: they cannot correct it) the mass and
    trunk stay; the residual still falls under 1 % BW."""
    h, t, q, _ = walk
    moved = _wobbled(t, q)
    d = derivatives(h.model, t, moved)
    loads = estimate_loads(h, *d)
    r = reduce_residuals(h, t, moved, loads)
    assert r.mass == h.mass and not np.any(r.com_shift)
    assert r.force_rms() < 0.01 * h.mass * 9.81
    assert r.force_rms() < r.force_rms(False)


def test_standing_feet_stay_on_their_floor(walk):
    """Markers with 5 mm of noise (seeded), fitted, loads estimated, reduced: the residual
    alone is as small with the pelvis lowered 3 cm (a vertical residual is an acceleration,
    not a height) and the standing feet then go through the floor, which no tracking on it
    can follow. The feet term holds a foot that carries over 10 % BW at the height and tilt
    the motion had (measured: the worst standing foot 7.3 mm off, 35.6 without the term; the
    residual 7.4 -> 2.9 % BW, 1.2 without)."""
    from humanoid.motion.ik import inverse_kinematics
    from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions

    h, t, q, _ = walk
    markers = default_markers(h)
    clean = marker_positions(h, q, markers)
    noisy = clean + np.random.default_rng(0).normal(scale=0.005, size=clean.shape)
    fit = inverse_kinematics(h, MarkerTrajectories(t, list(markers), noisy), markers)
    loads = estimate_loads(h, *derivatives(h.model, t, fit.q))
    r = reduce_residuals(h, t, fit.q, loads)
    assert r.force_rms() < 0.05 * h.mass * 9.81 < r.force_rms(False)
    data, worst = h.model.createData(), 0.0
    carried = {x.body: x.force[:, 2] > 0.1 * h.mass * 9.81 for x in r.loads}
    for side, on in carried.items():
        for k in np.flatnonzero(on):
            z = []
            for x in (r.q[k], r.q_before[k]):
                pin.framesForwardKinematics(h.model, data, x)
                z.append(data.oMf[h.sole_id(side)].translation[2])
            worst = max(worst, abs(z[0] - z[1]))
    assert worst < 0.01


def test_reduction_errors(walk):
    h, t, q, loads = walk
    with pytest.raises(HumanoidError, match="ground forces"):
        reduce_residuals(h, t, q, [])
    for bad in (0.0, -1.0, float("nan"), "2 mm", True):
        with pytest.raises(HumanoidError, match=r"sigma_contact must be a positive number"):
            reduce_residuals(h, t, q, loads, sigma_contact=bad)
    with pytest.raises(HumanoidError, match=r"sigma_root must be a positive number"):
        reduce_residuals(h, t, q, loads, sigma_root=0)
