"""OpenSim 4 as a peer of the toolkit's inverse dynamics (``opensim`` is a test dependency).

The male body written as an OpenSim model (``humanoid.motion.opensim_peer``) and one motion
through both: a still pose gives the same generalised forces to OpenSim's printing (8
decimals); a moving one differs only by how each differentiates the motion (OpenSim's tool
fits a quintic GCV smoothing spline to the angles, the toolkit differences on the group).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model

from humanoid.motion.inverse_dynamics import inverse_dynamics
from humanoid.motion.loads import Load
from humanoid.motion.opensim_peer import osim_generalized_forces, run_opensim_id, to_osim


def _both(tmp_path, h, t, q, loads):
    theirs, _ = run_opensim_id(h, t, q, loads, tmp_path)
    r = inverse_dynamics(h, t, q, loads, cutoff=None)
    ours = osim_generalized_forces(h, to_osim(h), r.time, r.q, r.tau)
    assert sorted(ours.labels) == sorted(theirs.labels)
    np.testing.assert_allclose(theirs.time, ours.time, atol=1e-9)
    theirs.data = np.column_stack([theirs.column(c) for c in ours.labels])
    theirs.labels = list(ours.labels)
    return ours, theirs


def test_a_still_pose_with_loads_matches_opensim(tmp_path):
    """A random pose held still, a load under each foot off its sole's middle: every
    generalised force (the root's residuals too) equal to OpenSim's to 1e-6."""
    h = get_model("male", "quaternion")
    model = h.model
    rng = np.random.default_rng(1)
    q = np.tile(pin.integrate(model, h.standing_configuration(), rng.normal(size=model.nv) * 0.3),
                (20, 1))  # fmt: skip
    t = np.arange(20) * 0.01
    data = model.createData()
    pin.framesForwardKinematics(model, data, q[0])
    loads = []
    for s, f in (("left", [20.0, -10.0, 300.0]), ("right", [-15.0, 5.0, 400.0])):
        p = data.oMf[h.sole_id(s)].translation + [0.03, 0.01, 0.0]
        loads.append(Load(s, t, np.tile(f, (20, 1)), np.tile(p, (20, 1)),
                          np.tile([0.0, 0.0, 2.0], (20, 1))))  # fmt: skip
    ours, theirs = _both(tmp_path, h, t, q, loads)
    np.testing.assert_allclose(ours.data[2:-2], theirs.data[2:-2], atol=1e-6)


def test_a_moving_body_matches_opensim_to_its_spline(tmp_path, walk_motion):
    """The walk (100 Hz, filtered at 6 Hz) with its ground forces: the knees' and ankles'
    moments within 1 % of their peak of OpenSim's, the root's residual forces within 5 % of
    body weight, every other within 5 % of the largest generalised force (the two
    differentiate the motion differently: the root's vertical residual differs by 24 N, 3.3 %
    of body weight, at 0.86 s, where ours is 0.1 N)."""
    h, t, q, loads = walk_motion
    ours, theirs = _both(tmp_path, h, t, q, loads)
    inner = slice(10, -10)
    peak = np.abs(theirs.data[inner]).max()
    weight = h.mass * 9.81
    for i, c in enumerate(ours.labels):
        diff = np.abs(ours.data[inner, i] - theirs.data[inner, i]).max()
        if "knee" in c or "ankle" in c:
            assert diff < 0.01 * np.abs(theirs.data[inner, i]).max(), c
        elif c.startswith("root_joint") and c.endswith("_force"):
            assert diff < 0.05 * weight, (c, diff)
        else:
            assert diff < 0.05 * peak, (c, diff, peak)


@pytest.fixture(scope="module")
def walk_motion(walk_1khz):
    """The walk at 100 Hz (every tenth step), filtered at 6 Hz, with its ground forces."""
    from humanoid.motion.inverse_dynamics import derivatives

    h, tr = walk_1khz
    t, q, _, _ = derivatives(h.model, tr.t[::10], tr.q[::10], cutoff=6.0)
    loads = [Load.from_wrench(s, tr.t, tr.forces[f"ground_{s}"]) for s in ("left", "right")]
    return h, t, q, loads
