"""The reference gait: a person's normative gait cycle fitted to the body (kinematics only)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import humanoid as hm
from humanoid.constraints.limits import JointRanges
from humanoid.walking.clinical import ANGLES, clinical_angles
from humanoid.walking.norms import norms
from humanoid.walking.reference import CLEARANCE, fit_cycle, lateral_sway


@pytest.fixture(scope="module")
def male():
    h = hm.load("adult_male")
    return h, fit_cycle(h)


def test_the_cycle_is_a_persons_walk(male):
    """Free speed, cadence and step length in the adult norms; feet flat, then rolling; the
    knee straight at heel strike, flexing in loading and in swing as people do; the centre of
    mass rising and falling 3-5 cm and swaying under 5 cm; every joint inside its range."""
    h, c = male
    g = c.gait
    assert 1.25 <= g["speed"] <= 1.45 and 100 <= g["cadence"] <= 120
    assert 0.65 <= g["step_length"] <= 0.80 and 0.18 <= g["double_support"] <= 0.26
    assert c.residual < 1e-4  # the stance feet's poses [m, rad]
    knee = clinical_angles(h, c.q)["right"][:, ANGLES.index("knee_flexion")]
    assert knee[0] < 10.0
    assert 10.0 <= knee[c.phase < 0.3].max() <= 25.0
    assert 55.0 <= knee.max() <= 70.0
    m, d = h.model, h.model.createData()
    com = np.array([pin.centerOfMass(m, d, q) for q in c.q])
    assert 0.03 <= np.ptp(com[:, 2]) <= 0.05
    assert np.ptp(com[:, 1]) < 0.05
    ranges = JointRanges(h)
    assert max(ranges.violation(q) for q in c.q) < np.radians(1e-4)


def test_each_foot_strikes_with_the_heel_and_leaves_from_the_toes(male):
    h, c = male
    for side in ("left", "right"):
        kinds = c.contact[side]
        shift = 0.5 if side == "left" else 0.0
        order = kinds[np.argsort((c.phase + shift) % 1.0)]  # from the side's heel strike
        runs = [int(k) for i, k in enumerate(order) if i == 0 or k != order[i - 1]]
        assert runs == [1, 2, 3, 0], (side, runs)  # heel, flat, toes, swing
        # a flat foot does not move; the swing foot clears the floor
        flat = c.feet[side][kinds == 2]
        assert np.ptp(flat, axis=0).max() < 1e-4
        m, d = h.model, h.model.createData()
        corners = [h.frame_id(n) for n in h.require_contact_points(side)]
        lowest = []
        for q in c.q[kinds == 0]:
            pin.framesForwardKinematics(m, d, q)
            lowest.append(min(d.oMf[f].translation[2] for f in corners))
        assert min(lowest) > 0.0 and np.max(lowest) > CLEARANCE


def test_the_angles_follow_the_norms(male):
    """The fitted angles stay close to the normative means (RMS over the cycle, degrees)."""
    h, c = male
    n = norms()
    v_hat = c.gait["dimensionless_speed"]
    a = clinical_angles(h, c.q)["right"]
    for name, bound in (("hip_flexion", 6.0), ("knee_flexion", 6.0), ("ankle_dorsiflexion", 6.0)):
        mean = np.interp(c.phase * 100, n.percent, n.curve(name, v_hat)[0])
        if name == "hip_flexion":  # the lab's pelvis tilt offset, which the body does not have
            mean = mean - n.curve("pelvis_tilt", v_hat)[0].mean()
        rms = np.sqrt(np.mean((a[:, ANGLES.index(name)] - mean) ** 2))
        assert rms < bound, (name, rms)


def test_lateral_sway_of_an_inverted_pendulum():
    """The periodic pendulum path: symmetric, inside the feet (the body never gets over the
    stance foot: +-1.7 cm for these numbers, from y_max = w/2 (1 - 1/cosh(T/2 tau)) of the
    pendulum without double support, 2.3 cm), and across the middle in the double support."""
    phase = np.arange(400) / 400
    y = lateral_sway(phase, 1.0, 0.12, 0.95, 0.2)
    assert abs(y.max() + y.min()) < 1e-9
    tau = np.sqrt(0.95 / 9.81)
    assert 0.005 < y.max() < 0.06 * (1 - 1 / np.cosh(0.5 / (2 * tau)))
    assert abs(y[20]) < 1e-3  # phase 0.05: the middle of the double support
