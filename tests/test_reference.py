"""The reference gait: a person's normative gait cycle fitted to the body (kinematics only)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import humanoid as hm
from humanoid.constraints.limits import JointRanges
from humanoid.control.tasks import closest_in_hull
from humanoid.model import lock_foot_hinges
from humanoid.scene import Effects, GroundSpec, JointLimitSpec, Scene
from humanoid.simulation import Simulation
from humanoid.walking.clinical import ANGLES, arm_chains, clinical_angles
from humanoid.walking.norms import norms
from humanoid.walking.reference import CLEARANCE, fit_cycle, periodic_pendulum
from humanoid.walking.tracking import CyclePlayer, GaitController, TrackingGains


@pytest.fixture(scope="module")
def male():
    """The male body as the fitted cycle walks it (its toes locked), and its cycle."""
    h = lock_foot_hinges(hm.load("adult_male"))
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
    # smooth through heel strike: the centre of mass falls at most 0.6 m/s, the landing foot
    # at most 1 m/s (a swing that stayed 4 cm up until the last frame dropped them at 1.5 and
    # 1.9 m/s, and a controller tracking that lifted the body off its feet)
    dt = c.period / len(c.phase)
    assert np.abs(np.diff(com[:, 2])).max() / dt < 0.6
    for side in ("left", "right"):
        z = c.feet[side][:, 2]
        landing = (c.contact[side] != 0) & (np.roll(c.contact[side], 1) == 0)
        assert np.abs(z - np.roll(z, 1))[landing].max() / dt < 1.0
        # and smooth through foot off: the swing leaves from the stance pose (bent from the
        # first swing frame: from the last stance frame, it left at 1.4 m/s across and
        # 13 rad/s of yaw, and the g1's at 3 m/s, its swing pulling the body over)
        lift = (c.contact[side] == 0) & (np.roll(c.contact[side], 1) != 0)
        jump = np.abs(c.feet[side] - np.roll(c.feet[side], 1, axis=0))[lift] / dt
        assert jump[:, :3].max() < 0.5 and jump[:, 3:].max() < 4.0, jump
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
        # the path rises to CLEARANCE at mid-swing, which falls between two frames
        assert min(lowest) > 0.0 and np.max(lowest) > 0.95 * CLEARANCE


def test_the_angles_follow_the_norms(male):
    """The fitted angles stay close to the normative means (RMS over the cycle, degrees). The
    knee's is the largest (6.8 measured, male body): the trailing knee flexes from 42 % of the
    cycle, about 8 degrees earlier than the norm, lowering the body for the leading heel."""
    h, c = male
    n = norms()
    v_hat = c.gait["dimensionless_speed"]
    a = clinical_angles(h, c.q)["right"]
    for name, bound in (("hip_flexion", 6.0), ("knee_flexion", 7.5), ("ankle_dorsiflexion", 6.0)):
        mean = np.interp(c.phase * 100, n.percent, n.curve(name, v_hat)[0])
        if name == "hip_flexion":  # the lab's pelvis tilt offset, which the body does not have
            mean = mean - n.curve("pelvis_tilt", v_hat)[0].mean()
        rms = np.sqrt(np.mean((a[:, ANGLES.index(name)] - mean) ** 2))
        assert rms < bound, (name, rms)


def test_the_arms_swing_opposite_the_legs(male):
    """Each arm swings against its own leg: most back at its own heel strike, most forward at
    the other's, over a 30-degree arc at free speed (Perry & Burnfield), to within 2 degrees;
    the elbow bends more when the arm is forward."""
    h, c = male
    arms = arm_chains(h)
    m, d = h.model, h.model.createData()
    hip = clinical_angles(h, c.q)
    for side, arm in arms.items():
        a = []
        for q in c.q:
            pin.framesForwardKinematics(m, d, q)
            a.append(arm.angles(d))
        shoulder, elbow = np.array(a).T
        assert abs(np.ptp(shoulder) - 30.0) < 2.0, (side, np.ptp(shoulder))
        own = hip[side][:, ANGLES.index("hip_flexion")]
        assert np.corrcoef(shoulder, own)[0, 1] < -0.85  # -0.90 measured (the hip is no sine)
        assert np.corrcoef(shoulder, elbow)[0, 1] > 0.9
    strike = {"right": 0, "left": len(c.phase) // 2}
    for side, i in strike.items():  # at its own heel strike an arm is at its most back
        pin.framesForwardKinematics(m, d, c.q[i])
        assert arms[side].angles(d)[0] < -13.0


def test_lateral_sway_of_an_inverted_pendulum():
    """The periodic pendulum path over a zero-moment point that steps from foot to foot:
    symmetric, inside the feet (the body never gets over the stance foot: +-1.7 cm for these
    numbers, below y_max = w/2 (1 - 1/cosh(T/2 tau)) of the pendulum without double support,
    2.3 cm), and across the middle in the double support."""
    from humanoid.walking.plan import smooth_step

    n, w, ds = 400, 0.12, 0.2
    psi = np.arange(n) / n

    def zmp(x):  # from the left foot to the right in the double support from 0, and back
        if x < ds / 2:
            return w / 2 - w * float(smooth_step(x / (ds / 2)))
        if x < 0.5:
            return -w / 2
        if x < 0.5 + ds / 2:
            return -w / 2 + w * float(smooth_step((x - 0.5) / (ds / 2)))
        return w / 2

    y = periodic_pendulum(np.array([zmp(x) for x in psi]), 9.81 / 0.95, 1.0 / n)
    assert abs(y.max() + y.min()) < 1e-9
    tau = np.sqrt(0.95 / 9.81)
    assert 0.005 < y.max() < 0.06 * (1 - 1 / np.cosh(0.5 / (2 * tau)))
    assert abs(y[20]) < 1e-3  # phase 0.05: the middle of the double support


def test_the_cycle_player_passes_through_the_cycle(male):
    """The reference as a function of time: through every fitted instant exactly, one stride
    further each lap, and a flat foot nearly still between the instants (< 3 cm/s where its
    neighbours are flat too: the spline through the joint angles at 2 % steps; 2.3 cm/s
    measured, male body)."""
    h, c = male
    m, d = h.model, h.model.createData()
    player = CyclePlayer(m, c)
    T = c.period
    for phi, q in zip(c.phase, c.q, strict=True):
        assert np.abs(pin.difference(m, player.configuration(phi * T), q)).max() < 1e-9
    later = player.configuration(1.3 * T)
    now = player.configuration(0.3 * T)
    now[0] += c.stride
    assert np.abs(pin.difference(m, now, later)).max() < 1e-9
    flat = c.contact["right"] == 2
    for i in np.flatnonzero(flat & np.roll(flat, 1) & np.roll(flat, -1)):
        q, v, _ = player.state(c.phase[i] * T)
        pin.forwardKinematics(m, d, q, v)
        pin.updateFramePlacements(m, d)
        foot = pin.getFrameVelocity(m, d, h.sole_id("right"), pin.LOCAL_WORLD_ALIGNED)
        assert np.linalg.norm(foot.linear) < 0.03


def test_the_tracking_controller_and_the_ground_agree(male):
    """A few steps of the tracking controller on the rigid ground contact, from the cycle's
    own state at 20 % (right foot flat, left swinging): the plant's accelerations are the
    controller's (relative 1e-5: the contact solver's tolerance), the free flyer gets no
    torque, and the ground's total impulse is the controller's planned forces times dt. (With
    the plant's own contact rule: a point touches within 0.2 mm and sticks within one step;
    the walk's defaults settle a point within 2 mm onto the floor over 20 ms instead.)"""
    h, c = male
    scene = Scene(
        name="track", body=h.source, ball_joints=h.ball_joints, duration=0.03, dt=1e-3,
        integrator="semi_implicit_euler",
        effects=Effects(joint_limits=JointLimitSpec(kind="constraint"),
                        ground=GroundSpec(bodies="feet")),
    )  # fmt: skip
    sim = Simulation(scene, humanoid=h)
    # (and its free points kept off the floor within the step, not 20 ms ahead: else the
    # plant stops a point the controller let approach)
    exact = TrackingGains(touch=2e-4, settle=0.0, contact_time=0.0, horizon=1e-3)
    ctl = GaitController(h, sim.model, c, sim.ground, scene.dt, phase0=0.2, gains=exact)
    q0, v0, _ = ctl.player.state(0.0)
    seen = []

    class Agreement:
        def observe(self, sim, k, t, q, v, step):
            dv, f, loaded = ctl.last
            a = (step.v - v) / scene.dt
            total = sim.ground_step.impulses.sum(axis=0)
            planned = scene.dt * f.sum(axis=0)
            seen.append((
                np.abs(a - dv).max() / np.abs(dv).max(),
                np.abs(step.torque[:6]).max(),
                np.abs(total - planned).max() / np.abs(planned).max(),
                len(loaded),
            ))  # fmt: skip

    traj = sim.run(quiet=True, controller=ctl, monitors=[Agreement()], initial=(q0, v0))
    assert traj.metadata["status"] == "completed"
    seen = np.array(seen)
    assert len(seen) == 30 and seen[:, 3].min() == 4  # the flat right foot's four corners
    assert seen[:, 0].max() < 1e-5
    assert seen[:, 1].max() == 0.0
    assert seen[:, 2].max() < 1e-5
    # the swing foot's path: the cycle's own swing, from the foot's lift-off pose and velocity
    # (no jump in its target when it leaves the floor rolling over its toes) to the next
    # heel-strike pose (a little into the floor), raised LIFT in the middle
    from humanoid.walking.tracking import LIFT, REACH

    k, _ = ctl.side_phase("left", 0.0)
    rd = h.model.createData()
    sole = h.sole_id("left")
    lwa = pin.LOCAL_WORLD_ALIGNED

    def path(psi, M0, v0):
        t = (k + psi - 0.5 - ctl.player.phase0) * c.period  # the left side's phase is psi
        q, v, a = ctl.player.state(t)
        pin.forwardKinematics(h.model, rd, q, v, a)
        M = pin.updateFramePlacement(h.model, rd, sole)
        vel = pin.getFrameVelocity(h.model, rd, sole, lwa).vector
        acc = pin.getFrameClassicalAcceleration(h.model, rd, sole, lwa).vector
        return ctl.swing_path("left", k, psi, M0, v0, (M.copy(), vel, acc)), (M, vel, acc)

    ctl.lift.clear()  # a new swing: it starts where the foot is
    M0 = pin.SE3(pin.utils.rotate("y", -0.6), np.array([0.1, 0.06, 0.08]))
    v0 = np.array([1.2, 0.05, 0.3])
    off = ctl.off
    start, cycle_start = path(off, M0, v0)
    end, cycle_end = path(1.0, M0, v0)
    middle, cycle_middle = path((1 + off) / 2, M0, v0)
    land = ctl.landing("left", k + 1)
    assert np.abs(pin.log6(start[0].actInv(M0)).vector).max() < 1e-12
    assert np.abs(start[1][:3] - v0).max() < 1e-12
    assert np.abs(start[2][:3] - cycle_start[2][:3]).max() < 1e-9  # the cycle's acceleration
    goal = pin.SE3(land.rotation, land.translation - [0.0, 0.0, REACH])
    assert np.abs(pin.log6(end[0].actInv(goal)).vector).max() < 1e-9
    assert np.abs(end[1] - cycle_end[1]).max() < 1e-9  # it lands as the cycle's foot does
    # in the middle: the cycle's foot, half the reach down, LIFT up, half the lift-off error
    # back and the velocity error's Hermite term (5/32 of the swing's duration times it)
    # (carried halfway from the anchor of the footstep it left to that of the next)
    duration = (1 - off) * c.period
    a0, a1 = ctl.anchor("left", k), ctl.anchor("left", k + 1)
    assert a0[2] == a1[2] == 0.0  # straight ahead: the anchors only shift
    e_p = M0.translation - cycle_start[0].translation - [a0[0], a0[1], 0.0]
    e_v = v0 - cycle_start[1][:3]
    shift = [(a0[0] + a1[0]) / 2, (a0[1] + a1[1]) / 2, LIFT - REACH / 2]
    expected = cycle_middle[0].translation + e_p / 2 + 5 / 32 * duration * e_v + shift
    assert np.abs(middle[0].translation - expected).max() < 1e-12
    # and by finite differences, the velocity and acceleration are the path's (to the cycle
    # player's own central differences, O(h^2) with h = 2 ms)
    eps = 1e-6
    ahead, _ = path((1 + off) / 2 + eps, M0, v0)
    behind, _ = path((1 + off) / 2 - eps, M0, v0)
    dt = 2 * eps * c.period
    fd = (ahead[0].translation - behind[0].translation) / dt
    assert np.allclose(fd, middle[1][:3], atol=1e-3)
    assert np.allclose(pin.log3(ahead[0].rotation @ behind[0].rotation.T) / dt, middle[1][3:],
                       atol=1e-3)  # fmt: skip
    assert np.allclose((ahead[1] - behind[1]) / dt, middle[2], atol=1e-2)
    # along a curve the two footsteps' anchors differ in yaw: the path turns with them, and
    # its velocity and acceleration are still its own (the turn of the cycle's point, metres
    # from the origin, was missing from them: 2 m/s off, and every curve fell); to 1e-2 here,
    # the player's central differences being coarser away from mid-swing (4e-3 m/s in z)
    ctl.anchors["left"][k] = np.array([0.3, -0.2, 0.1])
    ctl.anchors["left"][k + 1] = np.array([0.1, 0.4, 0.35])
    for psi in (off + 0.3 * (1 - off), (1 + off) / 2, off + 0.7 * (1 - off)):
        ctl.lift.clear()
        start, _ = path(off, M0, v0)
        now, _ = path(psi, M0, v0)
        ahead, _ = path(psi + eps, M0, v0)
        behind, _ = path(psi - eps, M0, v0)
        assert np.abs(pin.log6(start[0].actInv(M0)).vector).max() < 1e-12
        v_fd = (ahead[0].translation - behind[0].translation) / dt
        w_fd = pin.log3(ahead[0].rotation @ behind[0].rotation.T) / dt
        assert np.allclose(v_fd, now[1][:3], atol=1e-2), (v_fd, now[1])
        assert np.allclose(w_fd, now[1][3:], atol=1e-2), (w_fd, now[1])
        assert np.allclose((ahead[1] - behind[1]) / dt, now[2], atol=5e-2)


def test_a_double_support_splits_the_load_as_the_plan_does(male):
    """The load-share row is zero exactly when the leading foot carries the plan's share w of
    the vertical load (the smooth step the planned centre of pressure takes from the trailing
    foot to the leading one), whatever the points' horizontal forces; outside a double support
    (a foot in swing, or the leading foot past its foot flat) there is no row."""
    from humanoid.walking.plan import smooth_step

    h, c = male
    scene = Scene(name="share", body=h.source, ball_joints=h.ball_joints, duration=0.01,
                  integrator="semi_implicit_euler",
                  effects=Effects(ground=GroundSpec(bodies="feet")))  # fmt: skip
    sim = Simulation(scene, humanoid=h)
    ctl = GaitController(h, sim.model, c, sim.ground, scene.dt)
    flat = c.gait["opposite_foot_off"]
    side_of = ["right", "right", "left", "left", "left"]  # two leading points, three trailing
    loaded = [0, 1, 2, 3, 4]
    rng = np.random.default_rng(3)
    for psi in (0.0, 0.3 * flat, 0.8 * flat):
        steps = {"right": (1, psi), "left": (0, 0.5 + psi)}
        row = ctl.load_share(steps, {"right": 1, "left": 3}, side_of, loaded)
        w = float(smooth_step(psi / flat))
        f = rng.normal(size=(5, 3))  # horizontal forces do not matter
        f[:2, 2] = w * np.array([0.3, 0.7])  # the leading foot's share, over its points
        f[2:, 2] = (1 - w) * np.array([0.2, 0.5, 0.3])
        assert row @ f.ravel() == pytest.approx(0.0, abs=1e-12)
        f[0, 2] += 0.1  # more on the leading foot than the plan says
        assert abs(row @ f.ravel()) > 1e-3
    assert ctl.load_share({"right": (1, 0.1), "left": (0, 0.6)}, {"right": 1, "left": 0},
                          side_of, loaded) is None  # fmt: skip
    assert ctl.load_share({"right": (1, 1.2 * flat), "left": (0, 0.5 + 1.2 * flat)},
                          {"right": 2, "left": 3}, side_of, loaded) is None  # fmt: skip


def test_the_centre_of_mass_target_is_one_the_feet_can_carry():
    """closest_in_hull: a centre of pressure inside the soles stays; outside, it goes to the
    nearest point of their hull (an edge, a corner); two points are a segment, one a point."""
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]])
    assert np.allclose(closest_in_hull(np.array([0.3, 0.6]), square), [0.3, 0.6])
    assert np.allclose(closest_in_hull(np.array([2.0, 0.4]), square), [1.0, 0.4])
    assert np.allclose(closest_in_hull(np.array([-1.0, -2.0]), square), [0.0, 0.0])
    segment = np.array([[0.0, 0.0], [2.0, 0.0]])
    assert np.allclose(closest_in_hull(np.array([1.5, 0.7]), segment), [1.5, 0.0])
    assert np.allclose(closest_in_hull(np.array([3.0, 0.0]), segment), [2.0, 0.0])
    assert np.allclose(closest_in_hull(np.array([3.0, 3.0]), np.array([[1.0, 1.0]])), [1.0, 1.0])


def test_the_closest_point_of_the_hull_is_qhulls():
    """closest_in_hull (its own monotone chain) against Qhull's hull, on seeded supports as a
    controller sees them (two soles' corners, one sole's, a heel's edge, points on a line, a
    repeated point) and points inside and out: the same point to 1e-12."""
    from scipy.spatial import ConvexHull, QhullError

    def reference(p, pts):
        try:
            hull = ConvexHull(pts)
            if np.all(hull.equations[:, :2] @ p + hull.equations[:, 2] <= 1e-12):
                return p
            edges = [(pts[a], pts[b]) for a, b in hull.simplices]
        except (QhullError, ValueError):
            edges = [(a, b) for a in pts for b in pts]
        near = []
        for a, b in edges:
            ab = b - a
            u = 0.0 if ab @ ab < 1e-18 else float(np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0))
            near.append(a + u * ab)
        return min(near, key=lambda x: float(np.linalg.norm(x - p)))

    rng = np.random.default_rng(7)
    sole = np.array([[-0.05, -0.04], [0.15, -0.04], [0.15, 0.04], [-0.05, 0.04]])
    for _ in range(300):
        turn = rng.uniform(-np.pi, np.pi)
        R = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
        kind = rng.integers(5)
        if kind == 0:  # two soles
            pts = np.vstack([sole @ R.T, sole @ R.T + rng.uniform(-0.3, 0.3, 2)])
        elif kind == 1:  # one sole, and a point inside it
            pts = np.vstack([sole @ R.T, [[0.05, 0.0]]])
        elif kind == 2:  # a heel's edge
            pts = sole[[0, 3]] @ R.T
        elif kind == 3:  # on a line
            pts = np.outer(rng.uniform(-0.2, 0.2, 4), R[:, 0])
        else:  # one point, repeated
            pts = np.repeat(rng.uniform(-0.2, 0.2, (1, 2)), 2, axis=0)
        pts = pts + rng.uniform(-1.0, 1.0, 2)
        p = pts.mean(axis=0) + rng.normal(0.0, 0.15, 2)
        assert np.allclose(closest_in_hull(p, pts), reference(p, pts), atol=1e-12, rtol=0.0)


def test_the_centre_of_mass_plan_is_a_pendulum_over_the_feet(male):
    """The planned centre of mass: its derivatives are those of its path (central differences
    on the closed loop, to O(dt^2)); one stride a cycle on average; the floor pushes
    1 +- COM_BOB (4 pi / T)^2 / g body weights at its lowest and highest (3.5 cm p-p); the
    zero-moment point stays on the loaded feet (heel to toe edge, within the walking base); the
    forward speed peaks in the double support, as people's does."""
    from humanoid.walking.reference import COM_BOB

    h, c = male
    p = c.com
    n = len(p.phase)
    dt = p.period / n
    x = p.c.copy()
    x[:, 0] -= p.stride * p.phase  # periodic part
    fd = (np.roll(x, -1, axis=0) - np.roll(x, 1, axis=0)) / (2 * dt)
    fd[:, 0] += p.stride / p.period
    assert np.abs(fd[:, :2] - p.dc[:, :2]).max() < 1e-9
    assert np.abs(fd[:, 2] - p.dc[:, 2]).max() < 1e-3 * np.abs(p.dc[:, 2]).max()
    fdd = (np.roll(x, -1, axis=0) - 2 * x + np.roll(x, 1, axis=0)) / dt**2
    assert np.abs(fdd[:, :2] - p.ddc[:, :2]).max() < 1e-9  # the discrete pendulum exactly
    assert np.abs(fdd[:, 2] - p.ddc[:, 2]).max() < 1e-3 * np.abs(p.ddc[:, 2]).max()
    assert abs(p.dc[:, 0].mean() - p.stride / p.period) < 1e-9
    peak = COM_BOB * (4 * np.pi / p.period) ** 2 / 9.81
    assert (
        abs(p.ddc[:, 2].max() / 9.81 - peak) < 1e-3 and abs(p.ddc[:, 2].min() / 9.81 + peak) < 1e-3
    )
    assert 0.03 <= np.ptp(p.c[:, 2]) <= 0.05 and np.ptp(p.c[:, 1]) < 0.05
    # the zero-moment point between the rearmost heel and the foremost toe of the loaded feet
    L, width = c.gait["step_length"], c.gait["width"]
    assert np.abs(p.zmp[:, 1]).max() <= width / 2 + 1e-12
    heel = h.sole_points("right")[:, 0].min()
    toe = h.sole_points("right")[:, 0].max()
    x0 = float(c.feet["right"][0, 0])  # the right sole's origin on footstep 0
    for phi, z in zip(p.phase, p.zmp[:, 0], strict=True):
        feet = [x0 + 2 * L * np.floor(phi)]
        if phi < c.gait["opposite_foot_off"]:
            feet.append(x0 - L)
        elif phi >= 0.5:
            feet.append(x0 + L)
        lo = min(feet) + heel - 1e-9
        hi = max(feet) + toe + 1e-9
        assert lo <= z <= hi, (phi, z, lo, hi)
    ds = c.gait["opposite_foot_off"]
    fastest = p.phase[np.argmax(p.dc[:, 0])] % 0.5
    assert fastest <= ds + 0.02, fastest
    # at(phi) is continuous over laps (the end of a lap once blended in the first sample, a
    # stride behind): over three laps, no step of 1e-4 cycle moves it more than its top speed
    phis = np.linspace(0.0, 3.0, 30001)
    path = np.array([p.at(phi)[0] for phi in phis])
    step = np.linalg.norm(np.diff(path, axis=0), axis=1).max()
    assert step < 1.05 * np.linalg.norm(p.dc, axis=1).max() * p.period * 1e-4, step
    assert np.allclose(p.at(2.0)[0], p.c[0] + [2 * p.stride, 0, 0])


def test_the_centre_of_mass_plan_reads_like_np_interp(male):
    """``CenterOfMassPlan.at`` (one lookup for all nine columns) gives the same bits as
    ``np.interp`` column by column with ``period=1`` on the lap's samples, at the samples, on
    later and earlier laps (x one stride a lap further), and just below a lap's end."""
    _, c = male
    p = c.com
    rng = np.random.default_rng(3)
    phis = np.concatenate([rng.uniform(-3.0, 5.0, 500), p.phase, p.phase + 2.0,
                           [0.0, 1.0, 1.0 - 1e-12, -1e-17, p.phase[-1]]])  # fmt: skip
    periodic = p.c - np.outer(p.phase, [p.stride, 0.0, 0.0])
    for phi in phis:
        u = phi - np.floor(phi)
        want = [np.array([np.interp(u, p.phase, x[:, i], period=1.0) for i in range(3)])
                for x in (periodic, p.dc, p.ddc)]  # fmt: skip
        want[0][0] += p.stride * phi
        for got, w in zip(p.at(phi), want, strict=True):
            np.testing.assert_array_equal(got, w)
