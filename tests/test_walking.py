"""Walking: the plan, the CoM preview, and whole walks checked against the acceptance criteria."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import BODIES, get_model

import humanoid as hm
from humanoid.cli import main
from humanoid.walking import FootstepPlan, GaitParameters, PreviewController, com_trajectory, walk

LEFT, RIGHT = (0.065, 0.08), (0.065, -0.08)


def test_gait_parameters_are_validated_and_give_the_speed():
    g = GaitParameters()
    assert g.speed == pytest.approx(g.step_length / (g.t_single + g.t_double))
    assert g.speed >= 0.5, "the default walk must be at least 0.5 m/s"
    assert GaitParameters.for_speed(0.6).speed == pytest.approx(0.6)
    with pytest.raises(hm.HumanoidError, match=r"steps must be an integer in \[2, 1000\]"):
        GaitParameters(steps=1)
    with pytest.raises(hm.HumanoidError, match=r"t_single must be in \(0, 100\]"):
        GaitParameters(t_single=0.0)
    with pytest.raises(hm.HumanoidError, match="step_length must be at most 1 m"):
        GaitParameters(step_length=1.5)


def test_footsteps_alternate_and_end_with_the_feet_together():
    g = GaitParameters(steps=6, step_length=0.3)
    plan = FootstepPlan(g, LEFT, RIGHT)
    sides = [s.side for s in plan.steps]
    assert sides == ["right", "left"] * 3
    xs = [s.target[0] - LEFT[0] for s in plan.steps]
    assert np.allclose(xs[:-1], 0.3 * np.arange(1, 6))
    assert plan.final["left"][0] == pytest.approx(plan.final["right"][0])
    assert all(s.target[1] == pytest.approx((LEFT if s.side == "left" else RIGHT)[1])
               for s in plan.steps)  # fmt: skip
    # timing: single supports of t_single separated by double supports of t_double
    lifts = np.array([s.t_lift for s in plan.steps])
    assert np.allclose(np.diff(lifts), g.period)
    assert plan.stance(plan.steps[0].t_lift + 0.1) == {"left"}
    assert plan.stance(plan.steps[0].t_land + 0.01) == {"left", "right"}
    assert plan.duration == pytest.approx(plan.steps[-1].t_land + g.t_end)


def test_swing_foot_lands_softly_at_its_target():
    plan = FootstepPlan(GaitParameters(step_height=0.05), LEFT, RIGHT)
    step = plan.steps[2]
    eps = 1e-9
    p0, v0, a0 = plan.swing_reference(step.t_lift + eps)
    p1, v1, a1 = plan.swing_reference(step.t_land - eps)
    assert np.allclose(p0, [*step.start, 0.0], atol=1e-6)
    assert np.allclose(p1, [*step.target, 0.0], atol=1e-6)
    assert np.abs(v0).max() < 1e-6 and np.abs(v1).max() < 1e-6
    assert np.abs(a1[:2]).max() < 1e-5
    heights = [
        plan.swing_reference(t)[0][2] for t in np.linspace(step.t_lift, step.t_land, 101)[:-1]
    ]
    assert max(heights) == pytest.approx(0.05, rel=1e-3)
    # velocity is the derivative of position (finite differences)
    t, dt = step.t_lift + 0.2, 1e-6
    fd = (plan.swing_reference(t + dt)[0] - plan.swing_reference(t - dt)[0]) / (2 * dt)
    assert np.allclose(fd, plan.swing_reference(t)[1], atol=1e-5)


def test_zmp_reference_stays_in_the_support_polygon():
    g = GaitParameters(steps=4)
    plan = FootstepPlan(g, LEFT, RIGHT)
    half_width = 0.05
    for t in np.arange(0.0, plan.duration, 0.01):
        z = plan.zmp(t)
        feet = plan.feet_at(t)
        stance = plan.stance(t)
        if len(stance) == 1:
            foot = feet[stance.pop()]
            assert np.allclose(z, foot), t
        else:  # between the two feet (on the segment joining their centres)
            a, b = feet["left"], feet["right"]
            s = np.clip((z - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
            assert np.linalg.norm(a + s * (b - a) - z) < half_width, t


def test_preview_control_tracks_the_zmp_reference():
    plan = FootstepPlan(GaitParameters(steps=4), LEFT, RIGHT)
    t, c, dc, ddc, zmp, ref = com_trajectory(plan, 0.9, (LEFT[0], 0.0))
    settled = t > 0.5
    assert np.abs(zmp[settled] - ref[settled]).max() < 0.02
    assert np.allclose(c[-1], ref[-1], atol=5e-3)  # ends over the middle of the feet
    # the cart-table relation holds: zmp = c - z/g c''
    assert np.allclose(zmp, c - 0.9 / 9.81 * ddc)
    # a step in the reference is tracked with the classic preview behaviour
    ctl = PreviewController(5e-3, 0.8)
    step = np.where(np.arange(800) * 5e-3 < 2.0, 0.0, 0.1)
    x = ctl.run(step)
    assert x[-1, 0] == pytest.approx(0.1, abs=1e-3)
    assert x[380, 0] > 0.01  # the CoM starts moving before the ZMP reference does


@pytest.fixture(scope="module", params=["male", "female", "human"])
def walked(request):
    name = request.param
    h = get_model(name, "quaternion")
    return name, h, walk(h, GaitParameters(), quiet=True)


def test_walks_ten_steps_and_stops_standing(walked):
    name, h, result = walked
    assert result.trajectory.status == "completed", result.trajectory.metadata["message"]
    assert len(result.trajectory.metadata["footsteps"]) >= 10
    failed = {k: c for k, c in result.checks.items() if not c["ok"]}
    assert not failed, f"{name}: {failed}"
    s = result.summary
    assert s["speed"] >= 0.5, f"{name}: {s['speed']:.3f} m/s"
    # stops standing: both feet down, at rest, CoM between the feet
    traj = result.trajectory
    assert np.abs(traj.v[-1]).max() < 0.05
    assert (
        np.isfinite(traj.forces["left"][-1]).all() and np.isfinite(traj.forces["right"][-1]).all()
    )
    fz = traj.forces["left"][-1, 2] + traj.forces["right"][-1, 2]
    assert fz == pytest.approx(h.mass * 9.81, rel=0.02)
    x_end = traj.metadata["footsteps"][-1][1]
    assert abs(hm.centre_of_mass(h, traj.q[-1])[0] - x_end) < 0.05
    assert traj.q[-1, 0] > 3.0  # it went somewhere: ~3.2 m forward


def test_every_step_respects_the_contact_physics(walked):
    """The per-tick series behind the checks (not only their extremes)."""
    name, h, result = walked
    s = result.series
    assert np.all(s["tau_base"] == 0.0), "the free flyer is never actuated"
    fz = np.concatenate([s["fz_left"], s["fz_right"]])
    assert np.nanmin(fz) >= -1e-6
    assert np.nanmax(s["friction"]) <= 0.8
    assert np.nanmin(s["cop_margin"]) >= -1e-4
    assert np.nanmax(s["drift"]) < 1e-3
    assert np.nanmin(s["pelvis_z"]) > 0.8 * s["pelvis_z"][0]
    assert np.nanmax(s["tilt"]) < 30.0
    # controller and plant use the same contact equations: same accelerations
    assert np.nanmax(s["consistency"]) <= 1e-6
    # every joint inside its range at every tick (hinges, and ball joints by their triplet
    # angles), to round-off
    assert len(s["range"]) == len(s["t"]) and np.nanmax(s["range"]) <= 1e-6
    # touchdowns are soft: feet arrive slowly and the impulse changes velocities by little
    # (measured: up to 0.15 m/s and 1.2 rad/s on the female body, whose stance ankle rests on
    # its 20 deg dorsiflexion limit late in each stance with the feet flat; 0.07 m/s and
    # 0.5 rad/s on the male)
    impulses = s["impulse"][np.isfinite(s["impulse"])]
    assert len(impulses) == 10 and impulses.max() < 1.5
    events = result.trajectory.metadata["events"]
    speeds = [e["impact_speed"] for e in events if e["reason"] == "touchdown"]
    assert max(speeds) < 0.2, speeds
    assert sum(e["reason"] == "lift-off" for e in events) == 10
    assert sum(e["reason"] == "touchdown" for e in events) == 10


def test_walk_command_writes_the_run_the_figure_and_the_viewer(tmp_path, capsys):
    out = tmp_path / "walk.npz"
    html = tmp_path / "walk.html"
    code = main(["walk", "--gait", "welded", "--steps", "2", "--speed", "0.5", "-o", str(out),
                 "--html", str(html), "--quiet"])  # fmt: skip
    text = capsys.readouterr().out
    assert code == 0, text
    assert out.is_file() and html.is_file() and out.with_suffix(".png").is_file()
    for word in ("speed", "cadence", "double support", "peak vertical GRF", "typical adult",
                 "consistency", "real-time factor"):  # fmt: skip
        assert word in text
    assert main(["walk", "--gait", "welded", "--speed", "0.5", "--step-length", "0.3"]) == 2


def test_walk_of_an_unknown_model_is_a_clear_error(capsys):
    assert main(["walk", "--model", str(BODIES / "nope.urdf"), "--quiet"]) == 2
    assert "URDF file not found" in capsys.readouterr().err


def test_held_forces_are_the_plants_forces_between_qp_ticks():
    """With the QP every 8 ms, at every step in between the plant's welds carry exactly the
    last solve's contact forces (the held-forces torques), to 1e-6 of body weight."""
    from humanoid.walking.run import prepare

    h = get_model("male", "quaternion")
    setup = prepare(h, GaitParameters(steps=2))
    sim, ctl = setup.sim, setup.ctl
    ctl.every, ctl.period = 8, 8e-3
    weight, worst, held = h.mass * 9.81, 0.0, 0

    class Compare:
        def observe(self, sim, k, t, q, v, step):
            nonlocal worst, held
            if ctl.fresh or step.solution is None:
                return
            held += 1
            sim.kinematics(q, v)
            sim.store_forces(step.solution)
            for c in sim.contacts:
                if c.attached:
                    f = ctl.last[1][c.side]  # the QP's corner forces, world axes
                    worst = max(worst, float(np.abs(c.wrench[:3] - f.sum(axis=0)).max()))

    sim.scene = sim.scene.replace(duration=2.5)
    traj = setup.run(quiet=True, monitors=[Compare()])
    assert traj.status == "completed", traj.metadata["message"]
    assert held > 1500 and worst < 1e-6 * weight, (held, worst)


def test_walk_hold_is_validated():
    with pytest.raises(hm.HumanoidError, match="hold must be"):
        walk(get_model("male", "quaternion"), GaitParameters(steps=2), quiet=True, hold="both")
