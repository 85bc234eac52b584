"""Every force path conserves what it must: external pushes change momentum by their impulse
and are carried by the contacts; the MuJoCo peer sees the same momentum change."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import MODELS
from scipy.integrate import simpson

from humanoid.model import load
from humanoid.scene import Contact, Controller, Effects, Initial, PushSpec, Scene
from humanoid.simulate import simulate

MALE = str(MODELS / "adult_male.urdf")
FORCE = np.array([80.0, 20.0, -10.0])  # [N], world axes
TORQUE = np.array([0.0, 3.0, -2.0])  # [N m], world axes


def _momenta(h, traj, frame: str, force, torque):
    """Linear momentum, angular momentum about the CoM, and the moment about the CoM of the
    push (r x f + torque) at every record."""
    model, data = h.model, h.model.createData()
    fid = model.getFrameId(frame)
    p, L, moment = [], [], []
    for q, v in zip(traj.q, traj.v, strict=True):
        pin.computeCentroidalMomentum(model, data, q, v)
        pin.framesForwardKinematics(model, data, q)
        p.append(data.hg.linear.copy())
        L.append(data.hg.angular.copy())
        moment.append(np.cross(data.oMf[fid].translation - data.com[0], force) + torque)
    return np.array(p), np.array(L), np.array(moment)


@pytest.mark.parametrize("frame", ["pelvis", "thorax", "head"])
def test_a_push_changes_momentum_by_its_impulse(frame):
    """Free body in zero gravity, spinning and turned 90 deg about z (so that world and local
    axes differ), pushed for 0.2 s: delta p = F T and delta L about the CoM = the integral of
    r x F + torque, both to 1e-9 relative (RK4 at 0.5 ms; the angular impulse integrated with
    Simpson's rule over every step)."""
    h = load(MALE)
    q0 = h.standing_configuration()
    q0[3:7] = pin.Quaternion(pin.exp3(np.array([0.0, 0.0, np.pi / 2]))).coeffs()
    scene = Scene(
        body=MALE, duration=0.3, dt=5e-4, integrator="rk4", record_rate=2000.0,
        initial=Initial(configuration=tuple(q0), base_velocity=(0.2, 0.0, 0.1, 0.3, 1.0, 0.5)),
        effects=Effects(gravity=(0.0, 0.0, 0.0),
                        pushes=(PushSpec(frame, tuple(FORCE), 0.05, 0.2, tuple(TORQUE)),)),
    )  # fmt: skip
    traj = simulate(scene, humanoid=h, quiet=True)
    assert traj.status == "completed"
    p, L, moment = _momenta(h, traj, frame, FORCE, TORQUE)
    impulse = FORCE * 0.2
    assert np.abs(p[-1] - p[0] - impulse).max() <= 1e-9 * np.linalg.norm(impulse)
    on = (traj.t >= 0.05 - 1e-9) & (traj.t <= 0.25 + 1e-9)
    angular = simpson(moment[on], x=traj.t[on], axis=0)
    assert np.linalg.norm(angular) > 0.5  # a real test: the push turns the body [N m s]
    assert np.abs(L[-1] - L[0] - angular).max() <= 1e-9 * np.linalg.norm(angular)
    # outside the window nothing changes momentum
    before, after = traj.t < 0.05 - 1e-9, traj.t > 0.25 + 1e-9
    assert np.abs(p[before] - p[0]).max() < 1e-10
    assert np.abs(p[after] - p[-1]).max() < 1e-10


def test_a_slow_push_is_carried_by_the_feet():
    """Both feet welded, posture hold, a constant push for 2.5 s: once the body has settled,
    the horizontal foot reactions equal minus the push (static equilibrium), and the vertical
    ones the weight."""
    h = load(MALE)
    force = (40.0, 10.0, 0.0)
    scene = Scene(
        body=MALE, duration=3.0, dt=1e-3, integrator="rk4",
        effects=Effects(contacts=(Contact("left"), Contact("right")),
                        pushes=(PushSpec("thorax", force, 0.5, 2.5),)),
        controller=Controller("posture", frequency=8.0),
    )  # fmt: skip
    traj = simulate(scene, humanoid=h, quiet=True)
    assert traj.status == "completed"
    late = traj.t > 2.0
    feet = traj.forces["left"][late, :3] + traj.forces["right"][late, :3]
    assert np.abs(feet[:, 0] + force[0]).max() < 1e-6
    assert np.abs(feet[:, 1] + force[1]).max() < 1e-6
    assert np.abs(feet[:, 2] - h.mass * 9.81).max() < 1e-6 * h.mass * 9.81


def test_mujoco_sees_the_same_momentum_change():
    """The peer comparison's push: MuJoCo applies it through its own mj_applyFT. Both engines
    gain the impulse to 1e-9; the angular momentum changes agree to 5e-3 (MuJoCo holds the
    generalised force of a moving point constant over each 1 ms step; ours meets its own
    angular impulse to 1e-9)."""
    pytest.importorskip("mujoco")
    from humanoid.peers import MALE as PEER_MALE
    from humanoid.peers import push_momentum

    r = push_momentum(load(PEER_MALE))
    impulse = r["impulse"]
    for engine in ("humanoid", "mujoco"):
        assert np.abs(r[engine]["dp"] - impulse).max() < 1e-9 * np.linalg.norm(impulse)
    ours, theirs = r["humanoid"], r["mujoco"]
    assert np.abs(ours["dL"] - ours["angular_impulse"]).max() < 1e-9 * np.linalg.norm(ours["dL"])
    assert np.abs(ours["dL"] - theirs["dL"]).max() < 5e-3 * np.linalg.norm(ours["dL"])


def test_joint_limit_forces_push_back_inside():
    """Beyond its upper limit a hinge gets a negative torque, beyond its lower limit a positive
    one, nothing inside; the damping only opposes motion further out."""
    from humanoid.effects import JointLimits

    h = load(MALE, ball_joints="euler")
    model, data = h.model, h.model.createData()
    limits = JointLimits(model, stiffness=2000.0, damping=20.0)
    knee = model.joints[model.getJointId("left_knee")]
    lo, hi = model.lowerPositionLimit[knee.idx_q], model.upperPositionLimit[knee.idx_q]
    q, v = h.standing_configuration(), np.zeros(model.nv)
    for angle, speed, sign in ((hi + 0.01, 0.0, -1), (lo - 0.01, 0.0, 1),
                               (hi + 0.01, -1.0, -1), (0.5 * (lo + hi), 5.0, 0)):  # fmt: skip
        q[knee.idx_q], v[knee.idx_v] = angle, speed
        tau = limits.force(model, data, 0.0, q, v)
        assert np.sign(tau[knee.idx_v]) == sign, (angle, speed, tau[knee.idx_v])
        assert np.count_nonzero(tau) == abs(sign)
    q[knee.idx_q], v[knee.idx_v] = hi + 0.01, 1.0  # moving further out: more torque
    assert limits.force(model, data, 0.0, q, v)[knee.idx_v] < -2000.0 * 0.01 - 19.0
