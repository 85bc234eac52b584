"""Every force path conserves what it must: external pushes change momentum by their impulse
and are carried by the contacts; the MuJoCo peer sees the same momentum change."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import BODIES
from scipy.integrate import simpson

from humanoid.model import load
from humanoid.scene import Contact, Controller, Effects, Initial, PushSpec, Scene
from humanoid.simulation import simulate

MALE = str(BODIES / "adult_male.urdf")
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
    late = (traj.t > 2.0) & (traj.t < 3.0)  # at t = 3.0 the push is over (its last record)
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
    from humanoid.bench.common import load_male
    from humanoid.bench.peers import push_momentum

    r = push_momentum(load_male())
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
    limits = JointLimits(h, stiffness=2000.0, damping=20.0)
    knee = model.joints[model.getJointId("left_knee")]
    lo, hi = model.lowerPositionLimit[knee.idx_q], model.upperPositionLimit[knee.idx_q]
    q, v = h.standing_configuration(), np.zeros(model.nv)
    for angle, speed, sign in ((hi + 0.01, 0.0, -1), (lo - 0.01, 0.0, 1),
                               (hi + 0.01, -1.0, -1), (0.5 * (lo + hi), 5.0, 0)):  # fmt: skip
        q[knee.idx_q], v[knee.idx_v] = angle, speed
        tau = limits.force(model, data, 0.0, q, v)
        if sign == 0:  # inside every range: the effect adds nothing
            assert tau is None
            continue
        assert np.sign(tau[knee.idx_v]) == sign, (angle, speed, tau[knee.idx_v])
        assert np.count_nonzero(tau) == abs(sign)
    q[knee.idx_q], v[knee.idx_v] = hi + 0.01, 1.0  # moving further out: more torque
    assert limits.force(model, data, 0.0, q, v)[knee.idx_v] < -2000.0 * 0.01 - 19.0


def _thrown_into_the_ranges(limits, dt, T):
    """A free body in zero gravity whose joints are thrown hard (2.5 rad/s, seeded): every
    joint runs into its range within T; RK4."""
    from humanoid.scene import JointLimitSpec

    rng = np.random.default_rng(7)
    h = load(MALE)
    w = 2.5 * rng.choice([-1.0, 1.0], size=h.nv - 6)
    scene = Scene(body=MALE, duration=T, dt=dt, integrator="rk4", record_rate=1.0 / dt,
                  effects=Effects(gravity=(0.0, 0.0, 0.0), joint_limits=JointLimitSpec(*limits)),
                  initial=Initial(base_velocity=(0.1, 0.0, 0.2, 0.3, -0.2, 0.5),
                                  joint_velocity=tuple(w)))  # fmt: skip
    return h, simulate(scene, quiet=True)


def _momentum(h, traj):
    model, data = h.model, h.model.createData()
    out = []
    for q, v in zip(traj.q, traj.v, strict=True):
        pin.computeCentroidalMomentum(model, data, q, v)
        out.append(np.concatenate([data.hg.linear, data.hg.angular]))
    return np.array(out)


def test_joint_range_springs_conserve_momentum_and_energy():
    """Spring-mode ranges (hinges and the ball joints' triplet angles), undamped: internal
    forces, so the free body's momentum is constant, and conservative, so the kinetic energy
    plus the springs' potential k r^2 / 2 is constant. RK4 at 0.1 ms, 0.3 s: momentum to 1e-7
    relative (measured 1.2e-8: RK4 does not keep the momentum, a nonlinear function of the
    state, exactly), energy to 1e-4 (measured 5.7e-5: the potential is only C1 at a limit);
    the ranges were reached (the springs stored energy) by balls and hinges alike."""
    from humanoid.effects import JointLimits

    k = 2000.0
    h, traj = _thrown_into_the_ranges(("spring", k, 0.0), dt=1e-4, T=0.3)
    assert traj.status == "completed"
    P = _momentum(h, traj)
    assert np.abs(P - P[0]).max() < 1e-7 * np.abs(P[0]).max()
    springs = JointLimits(h, k, 0.0)
    potential = []
    balls = set()
    for q in traj.q:
        r, J = springs.ranges.rows(q, margin=0.0)
        potential.append(0.5 * k * float(r @ r))
        balls |= {int(np.flatnonzero(row)[0]) for row in J if np.count_nonzero(row) > 1}
    potential = np.array(potential)
    kinetic = traj.energy  # zero gravity: the recorded energy is kinetic
    total = kinetic + potential
    assert potential.max() > 1e-2 * kinetic[0]
    assert len(balls) >= 3  # rows of at least three ball joints pushed back
    assert np.abs(total - total[0]).max() < 1e-4 * total[0]


def test_joint_range_constraints_conserve_momentum_and_never_add_energy():
    """Constraint-mode ranges (unilateral rows of the contact solve, no ground), the free body
    thrown into them: step by step, the range impulses change neither the linear nor the
    angular momentum (A(q) dv = 0 to 1e-12 relative: they are internal) and never add kinetic
    energy (inelastic; 3e-8 relative, the solver's tolerance); many steps load them; every
    joint stays in its range (1 deg)."""
    from humanoid.constraints.limits import JointRanges
    from humanoid.scene import GroundSpec, JointLimitSpec
    from humanoid.simulation import Simulation

    rng = np.random.default_rng(7)
    h = load(MALE)
    model, data = h.model, h.model.createData()
    dt = 5e-4
    thrown = tuple(2.5 * rng.choice([-1.0, 1.0], h.nv - 6))
    scene = Scene(body=MALE, duration=0.6, dt=dt, integrator="semi_implicit_euler",
                  effects=Effects(gravity=(0.0, 0.0, 0.0), ground=GroundSpec(bodies=()),
                                  joint_limits=JointLimitSpec("constraint")),
                  initial=Initial(base_velocity=(0.1, 0.0, 0.2, 0.3, -0.2, 0.5),
                                  joint_velocity=thrown))  # fmt: skip
    sim = Simulation(scene, humanoid=h)
    ranges = JointRanges(h)
    q, v = sim.q0, sim.v0
    loaded, worst = 0, 0.0
    for k in range(int(round(scene.duration / dt))):
        v_free = v + dt * sim.plant.acceleration(k * dt, q, v)
        q_new, v_new = sim.plant.ground.advance(k * dt, q, v, dt)
        if np.abs(sim.ground_step.limit_impulses).max(initial=0.0) > 1e-9:
            loaded += 1
            A = pin.computeCentroidalMap(model, data, q)
            dv = v_new - v_free
            assert np.abs(A @ dv).max() < 1e-12 * np.abs(A @ v_free).max() + 1e-12
            ke_free = pin.computeKineticEnergy(model, data, q, v_free)
            # to the solver's tolerance: up to 1.35e-8 of itself measured (the toes' hinge)
            assert pin.computeKineticEnergy(model, data, q, v_new) <= ke_free * (1 + 3e-8)
        q, v = q_new, v_new
        worst = max(worst, ranges.violation(q))
    assert loaded > 100
    assert np.degrees(worst) < 1.0


def test_a_ball_joint_beyond_its_range_is_pushed_back():
    """The left hip flexed 0.05 rad past its range in quaternion mode: the spring's torque
    moves the flexion angle back (and only the hip's three rows are loaded)."""
    from humanoid.constraints.limits import JointRanges
    from humanoid.effects import JointLimits

    h = load(MALE)
    model, data = h.model, h.model.createData()
    ranges = JointRanges(h)
    k = next(i for i, (b, *_) in enumerate(ranges.balls) if b.name == "left_hip")
    ball, iq, iv, lo, hi = ranges.balls[k]
    q = h.standing_configuration()
    th = np.array([hi[0] + 0.05, 0.0, 0.0])
    q[iq : iq + 4] = pin.Quaternion(ball.rotation(th)).coeffs()
    limits = JointLimits(h, 2000.0, 20.0)
    tau = limits.force(model, data, 0.0, q, np.zeros(model.nv))
    acting = np.flatnonzero(tau).tolist()
    assert acting and set(acting) <= {iv, iv + 1, iv + 2}  # on that ball joint only
    after = ranges.angles(pin.integrate(model, q, 1e-6 * tau))[k]
    assert after[0] < hi[0] + 0.05 - 1e-6  # the flexion moved back towards its range


def test_a_ball_past_its_lock_gets_no_certificate_and_no_warning():
    """A ball whose middle angle is past the lock (a tumbling body) is certified clear of
    nothing, silently: the formula's other branch (a division by zero there) is not used."""
    import warnings

    import humanoid as hm
    from humanoid.constraints.limits import JointRanges

    h = hm.load("adult_male")
    ranges = JointRanges(h, compiled=False)
    q = h.standing_configuration()
    th = ranges._angles(q)
    th[:, 1] = np.pi
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ranges._certify(q, th, 0.05)
    _, _, up, down = ranges._certificate
    assert np.all(up[ranges._bv3] < 0) and np.all(down[ranges._bv3] > 0)
