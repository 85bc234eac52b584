"""Tracking with the toes free (``track(..., toes=True)``): the reference's toes turned onto
the floor, the sole points read on the toes themselves, the toe hinges kept and followed."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from conftest import get_model

SIDES = ("left", "right")


def _mtp(h, side: str) -> int:
    """The q index of a side's toe hinge."""
    return h.model.joints[h.model.getJointId(f"{side}_mtp")].idx_q


def _heights(h, q, names) -> np.ndarray:
    """The heights [m] of the named frames in configuration q."""
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, q)
    return np.array([data.oMf[h.frame_id(n)].translation[2] for n in names])


def _toe_points(h, side: str) -> list[str]:
    joint = h.model.getJointId(f"{side}_mtp")
    return [n for n in h.contact_points[side] if h.model.frames[h.frame_id(n)].parentJoint == joint]


def test_the_toes_through_the_floor_are_turned_onto_it():
    """Toes bent 0.3 rad down put their tips about 2.5 cm through the floor of a standing
    body: turned up until the tips are on it (to 0.1 mm), which is flat (the standing sole's
    plane); a frame whose toes are on the floor is left as it was, and the report names each
    hinge once per frame it turned."""
    from humanoid.motion.tracking import toes_on_floor

    h = get_model("male", "euler")
    up = h.standing_configuration()
    down = up.copy()
    for s in SIDES:
        down[_mtp(h, s)] = -0.3
    tips = [n for s in SIDES for n in _toe_points(h, s)]
    assert _heights(h, down, tips).min() < -0.02
    q, turned = toes_on_floor(h, np.array([up, down]), floor=0.0)
    np.testing.assert_array_equal(q[0], up)
    assert abs(_heights(h, q[1], tips).min()) < 1e-4
    for s in SIDES:
        assert abs(q[1, _mtp(h, s)]) < 1e-6
    assert set(turned) == {"left_mtp", "right_mtp"}
    assert all(k == 1 and abs(most - 0.3) < 1e-6 for k, most in turned.values())


def test_a_body_without_toe_hinges_is_left_alone():
    from humanoid.motion.tracking import toes_on_floor

    h = get_model("male_foot", "euler")
    q = h.standing_configuration()[None]
    out, turned = toes_on_floor(h, q - 0.0, floor=1.0)  # (every point under that floor)
    np.testing.assert_array_equal(out, q)
    assert turned == {}


def test_the_sole_points_are_read_on_the_toes_themselves():
    """With the toes bent down, the motion's lowest sole point and its contact schedule read the
    toe points where the toes have them (a rigid foot's sole points at MTP zero were read
    before: the toe tips 2.5 cm higher than they are)."""
    from humanoid.motion.coordinates import lowest_sole_point
    from humanoid.motion.inverse_dynamics import contact_schedule

    h = get_model("male", "euler")
    q = h.standing_configuration()
    for s in SIDES:
        q[_mtp(h, s)] = -0.3
    points = [n for s in SIDES for n in h.contact_points[s]]
    low = lowest_sole_point(h, q[None])
    assert low < -0.02
    assert abs(low - _heights(h, q, points).min()) < 1e-12
    # standing on the bent toes' tips: both feet down
    q[2] -= low
    n = 20
    t = np.arange(n) * 0.01
    qs, vs = np.tile(q, (n, 1)), np.zeros((n, h.nv))
    schedule = contact_schedule(h, t, qs, vs, height=0.005)
    assert all(schedule[s][1].all() for s in SIDES)


def test_tracking_keeps_the_toe_hinges_and_follows_their_angles():
    """A body standing with its toes bent 0.3 rad up (their tips 2.5 cm off the floor), tracked
    with its toes free: the run keeps the hinges (the locked body has none), each toe within a
    degree of its angle, the pelvis within 5 mm of the motion's and no sole point more than 1 mm
    in the floor."""
    from humanoid.motion.tracking import track

    h = get_model("male", "euler")
    q = h.standing_configuration()
    for s in SIDES:
        q[_mtp(h, s)] = 0.3
    t = np.arange(41) * 0.01
    res = track(h, t, np.tile(q, (len(t), 1)), cutoff=None, toes=True)
    assert res.completed, res.trajectory.metadata.get("message")
    assert res.body.nq == h.nq and res.toes == {}
    for s in SIDES:
        got = res.trajectory.q[:, _mtp(h, s)]
        assert np.degrees(np.abs(got - 0.3).max()) < 1.0
    assert np.abs(res.joint_error[:, :3]).max() < 5e-3
    points = [n for s in SIDES for n in h.contact_points[s]]
    low = min(_heights(h, qi, points).min() for qi in res.trajectory.q)
    assert low > -1e-3
    locked = track(h, t[:5], np.tile(q, (5, 1)), cutoff=None)
    assert locked.body.nq == h.nq - 2
