"""A pathological walk through the motion pipeline: a generated hemiparetic gait (a stroke
survivor's: a stiff knee, a foot drop, circumduction and a hip hike on one side), its markers
with noise, fitted, its loads estimated (no plates), its residuals reduced, and tracked on the
rigid ground to the end (``scripts/pathological.py`` runs more seeds, rates and settings)."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from gait_variants import hemiparetic

from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.inverse_dynamics import derivatives, estimate_loads
from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions
from humanoid.motion.reduce import reduce_residuals
from humanoid.motion.tracking import lost_at, track


@pytest.fixture(scope="module")
def hemiparetic_walk(walk_1khz):
    """The male body's 2-step walk with its right swing made hemiparetic, at 1 kHz: (body, t,
    q, the swing's weights, the walk's own q)."""
    h, tr = walk_1khz
    t, q, w = hemiparetic(h, tr.t, tr.q, tr.forces["ground_right"])
    return h, t, q, w, tr.q


def _rms(model, qa, qb) -> float:
    d = np.array([pin.difference(model, a, b)[6:] for a, b in zip(qa, qb, strict=True)])
    return float(np.degrees(np.sqrt(np.mean(d**2))))


def test_the_hemiparetic_swing_clears_the_floor(hemiparetic_walk):
    """The generated swing is one a person could make: the right knee bends less in swing
    (measured: at most 55 deg, the walk's 63), and no sole point goes through the floor (the
    hike lifts it)."""
    h, t, q, w, walk = hemiparetic_walk
    m = h.model
    knee = m.joints[m.getJointId("right_knee")].idx_q
    assert np.degrees(q[w > 0.0, knee].max()) < np.degrees(walk[w > 0.0, knee].max()) - 7.0
    data = m.createData()
    points = [h.frame_id(n) for n in h.require_contact_points("right")]
    low = np.inf
    for x in q[w > 0.0]:
        pin.framesForwardKinematics(m, data, x)
        low = min(low, *(data.oMf[f].translation[2] for f in points))
    assert low > -1e-3


@pytest.mark.parametrize(("every", "noise", "seed"), [(10, 0.005, 0), (33, 0.01, 1)])
def test_a_hemiparetic_walk_is_reduced_and_tracked_to_the_end(hemiparetic_walk, every, noise,
                                                              seed):  # fmt: skip
    """At 100 Hz with 5 mm of marker noise and at 30 Hz with 1 cm (video keypoints' rate),
    without plates: the residual after reduction under 5 % BW RMS, the tracked run completes
    without losing the motion (its pelvis within 10 cm and 15 deg) and its joints within 5 deg
    RMS of the walk (measured: 100 Hz 1.6 deg; 30 Hz 2.6)."""
    h, t, q, *_ = hemiparetic_walk
    t, q = t[::every], q[::every]
    markers = default_markers(h)
    clean = marker_positions(h, q, markers)
    noisy = clean + np.random.default_rng(seed).normal(scale=noise, size=clean.shape)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = inverse_kinematics(h, MarkerTrajectories(t, list(markers), noisy), markers)
    loads = estimate_loads(h, *derivatives(h.model, t, fit.q))
    red = reduce_residuals(h, t, fit.q, loads)
    assert red.force_rms() < 0.05 * h.mass * 9.81
    res = track(h, red.time, red.q)
    assert res.completed, res.trajectory.metadata.get("message")
    assert res.lost is None and lost_at(res.joint_error) is None
    run = res.trajectory
    walk = q[np.clip(np.searchsorted(t, run.t + red.time[0] - 1e-9), 0, len(q) - 1)]
    print(f"tracked {_rms(h.model, run.q, walk):.2f} deg RMS from the walk")
    assert _rms(h.model, run.q, walk) < 5.0
