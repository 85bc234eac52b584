"""The reference gait: a person's normative gait cycle fitted to the body (kinematics only)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import humanoid as hm
from humanoid.constraints.limits import JointRanges
from humanoid.scene import Effects, GroundSpec, JointLimitSpec, Scene
from humanoid.simulation import Simulation
from humanoid.walking.clinical import ANGLES, clinical_angles
from humanoid.walking.norms import norms
from humanoid.walking.reference import CLEARANCE, fit_cycle, lateral_sway
from humanoid.walking.tracking import CyclePlayer, GaitController


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


def test_the_cycle_player_passes_through_the_cycle(male):
    """The reference as a function of time: through every fitted instant exactly, one stride
    further each lap, and a flat foot nearly still between the instants (< 1 cm/s)."""
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
    for i in np.flatnonzero(c.contact["right"] == 2):
        q, v, _ = player.state(c.phase[i] * T)
        pin.forwardKinematics(m, d, q, v)
        pin.updateFramePlacements(m, d)
        foot = pin.getFrameVelocity(m, d, h.sole_id("right"), pin.LOCAL_WORLD_ALIGNED)
        assert np.linalg.norm(foot.linear) < 0.01


def test_the_tracking_controller_and_the_ground_agree(male):
    """A few steps of the tracking controller on the rigid ground contact, from the cycle's
    own state at 20 % (right foot flat, left swinging): the plant's accelerations are the
    controller's (relative 1e-5: the contact solver's tolerance), the free flyer gets no
    torque, and the ground's total impulse is the controller's planned forces times dt."""
    h, c = male
    scene = Scene(
        name="track", body=h.source, ball_joints=h.ball_joints, duration=0.03, dt=1e-3,
        integrator="semi_implicit_euler",
        effects=Effects(joint_limits=JointLimitSpec(kind="constraint"),
                        ground=GroundSpec(bodies="feet")),
    )  # fmt: skip
    sim = Simulation(scene, humanoid=h)
    ctl = GaitController(h, sim.model, c, sim.ground, scene.dt, phase0=0.2)
    sim.q0, sim.v0, _ = ctl.player.state(0.0)
    sim.controller = ctl
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

    sim.monitors.append(Agreement())
    traj = sim.run(quiet=True)
    assert traj.metadata["status"] == "completed"
    seen = np.array(seen)
    assert len(seen) == 30 and seen[:, 3].min() == 4  # the flat right foot's four corners
    assert seen[:, 0].max() < 1e-5
    assert seen[:, 1].max() == 0.0
    assert seen[:, 2].max() < 1e-5
