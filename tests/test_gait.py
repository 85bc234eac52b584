"""The walk on the rigid ground and the gait lab's analysis of it (humanoid.walking.gait)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import assert_heel_to_toe

import humanoid as hm
from humanoid.constraints.limits import JointRanges
from humanoid.errors import HumanoidError
from humanoid.model import SIDES, lock_foot_hinges
from humanoid.walking.gait import PERCENT, GaitRecord, analyse, pelvis_push, walk_on_ground
from humanoid.walking.reference import fit_cycle
from humanoid.walking.report import format_gait_table, gait_table, plot_gait_report


@pytest.fixture(scope="module")
def male():
    """The male body as the fitted cycle walks it: its toes locked."""
    return lock_foot_hinges(hm.load("adult_male"))


@pytest.fixture(scope="module")
def male_cycle(male):
    return fit_cycle(male)


@pytest.fixture(scope="module")
def male_walk(male, male_cycle):
    """Twenty steps of the male body at its free speed (about 60 s)."""
    walk = walk_on_ground(male, steps=20, cycle=male_cycle)
    return walk, analyse(male, walk)


@pytest.fixture(scope="module")
def female_walk():
    """Twenty steps of the female body at its free speed (about 55 s)."""
    h = lock_foot_hinges(hm.load("adult_female"))
    walk = walk_on_ground(h, steps=20)
    return h, walk, analyse(h, walk)


def _assert_a_persons_walk(h, walk, a, slip: float, speed: float) -> None:
    """The whole loop on the rigid ground (every sole point a frictional contact, the joint
    ranges as constraints, torques only): twenty heel strikes without a fall; every stance
    heel strike, foot flat, heel off, toe off, its loaded points sliding under ``slip``; the
    rhythm, knee and centre-of-mass motion of the adult norms, at least ``speed``; every joint
    in its range."""
    assert walk.completed, walk.trajectory.metadata["message"]
    assert walk.relaxed == 0
    strikes = sum(len(a.events[s]["strike"]) for s in SIDES)
    assert strikes >= 20, strikes
    stances = [f for s in SIDES for f in a.feet[s]]
    assert len(stances) >= 18
    for f in stances:
        assert f["heel_strike"] and f["flat"] and f["heel_off"] and f["toe_off"], f
        assert f["slip"] < slip, f
    s = a.summary
    assert s["cycles"] >= 14
    assert 100.0 <= s["cadence"] <= 120.0, s["cadence"]
    assert speed <= s["speed"] <= 1.45, s["speed"]
    assert s["knee_at_strike"] < 10.0, s["knee_at_strike"]
    assert 10.0 <= s["knee_loading"] <= 25.0, s["knee_loading"]
    assert 0.03 <= s["com_vertical"] <= 0.05, s["com_vertical"]
    assert s["com_lateral"] < 0.05, s["com_lateral"]
    # the swing knee: the cycle's own swing (55-70 degrees; 67 male, 65 female measured), not
    # the 90 degrees of a straight swing path
    assert s["knee_swing"] < 75.0, s["knee_swing"]
    # the arms swing opposite the legs, about the cycle's 30 degrees (36.6 male, 36.1 female
    # measured: they overshoot it a little); the pelvis tilts and turns
    assert 20.0 <= s["shoulder_flexion"] <= 45.0, s["shoulder_flexion"]
    assert s["arm_leg_correlation"] < -0.6, s["arm_leg_correlation"]
    assert s["pelvis_obliquity"] > 3.0 and s["pelvis_rotation"] > 3.0, s
    ranges = JointRanges(h)
    excess = max(ranges.excess(q).max() for q in walk.record.q[::20])
    assert excess < 2e-3, excess  # [rad]: the plant's range rows hold to their stabilisation


def test_the_g1_walks_ten_steps_through_the_same_pipeline():
    """example-robot-data's Unitree g1 (33 kg, 0.69 m legs) through the same fitted cycle,
    controller and ground as the bodies, at 0.6 m/s (its Froude free speed, 1.2 m/s, is beyond
    this controller yet; 0.7 fell at 4.8 s): ten heel strikes without a fall, heel to toe in
    every stance with slides under 2 mm, the speed it was asked, joints in their ranges."""
    h = hm.load("g1")
    walk = walk_on_ground(h, speed=0.6, steps=10)
    assert walk.completed, walk.trajectory.metadata["message"]
    a = analyse(h, walk)
    assert_heel_to_toe(a, strikes=10, stances=8)
    assert 0.55 <= a.summary["speed"] <= 0.70, a.summary["speed"]
    ranges = JointRanges(h)
    assert max(ranges.excess(q).max() for q in walk.record.q[::20]) < 2e-3


def test_the_erd_human_walks_eight_steps_through_the_same_pipeline():
    """example-robot-data's human (its ball joints as quaternions; its feet's collision shapes
    reach 5 and 10 mm up the back of the heel) at 0.8 m/s: eight steps without a fall, heel
    to toe in every stance, the speed it was asked, joints in their ranges. Seven heel strikes
    are asked, not eight: the stop's last strike (at 5.4 s of 5.68) was missed in 1 of 8 runs
    of the same walk (and in 1 of 3 fresh-clone suites): the walk differs from run to run by
    the QP's round-off, and the stop amplifies it. The walk is chaotic: before the footstep
    correction's larger share behind the plan (``TrackingGains.placement_behind``), 4 of 12
    walks started 1e-6 m/s apart fell at about 4.1 s, and a CI run fell there; with it, 24 of
    24 (1e-6 and 1e-4 m/s apart) completed. (It fell at every heel strike before the walk
    loaded only the soles' own points. It does not walk twenty yet: a 20-step walk fell at
    9.6 s; at 1.0 m/s it falls at 2.1 s. Its largest slide of a stance, above the issue's 2 mm,
    is chaotic too: 3.27-4.22 mm in 16 walks started 1e-6 m/s apart (median 3.38), 3.30-4.51
    in 12 started 1e-4 apart (median 3.37), 4.04 in a fresh-clone suite: the bound is 5 mm.
    ``python scripts/walk_robustness.py`` measures both.)"""
    h = hm.load("human")
    walk = walk_on_ground(h, speed=0.8, steps=8)
    assert walk.completed, walk.trajectory.metadata["message"]
    a = analyse(h, walk)
    assert_heel_to_toe(a, strikes=7, stances=6, slip=5e-3)
    assert 0.75 <= a.summary["speed"] <= 0.85, a.summary["speed"]
    ranges = JointRanges(h)
    assert max(ranges.excess(q).max() for q in walk.record.q[::20]) < 2e-3


def test_the_male_body_walks_twenty_steps_heel_to_toe(male, male_walk):
    """The male body's twenty steps (:func:`_assert_a_persons_walk`), and the recorded ground
    forces changing its momentum (:func:`_assert_forces_change_the_momentum`): one test, so
    that the walk is made once, not once in each pytest-xdist worker (about 50 s each)."""
    walk, a = male_walk
    # issue 13 asks slides under 2 mm (measured 2.1: not yet) and 1.25 m/s or more (1.40)
    _assert_a_persons_walk(male, walk, a, slip=4e-3, speed=1.25)
    assert 0.65 <= a.summary["step_length"] <= 0.80, a.summary["step_length"]  # 0.739
    _assert_forces_change_the_momentum(male, walk, a)


def test_the_female_body_walks_twenty_steps_heel_to_toe(female_walk):
    h, walk, a = female_walk
    # issue 13 asks slides under 2 mm (measured 2.7) and 1.25 m/s (measured 1.28)
    _assert_a_persons_walk(h, walk, a, slip=4e-3, speed=1.2)


def _momentum(model, data, rec, i: int) -> np.ndarray:
    """The body's linear momentum [N s] at row i of a record: mass times the CoM velocity."""
    pin.centerOfMass(model, data, rec.q[i], rec.v[i])
    return rec.mass * data.vcom[0].copy()


def _assert_forces_change_the_momentum(male, walk, a) -> None:
    """Over every analysed cycle, the feet's recorded forces and gravity change the body's
    linear momentum by their impulse (the record's forces are the plant's, in newtons)."""
    rec, model = walk.record, male.model
    data = model.createData()
    g = model.gravity.linear
    for t0, t1 in a.cycles["right"]:
        i0, i1 = np.searchsorted(rec.t, [t0, t1])
        impulse = sum(rec.force[s][i0:i1].sum(axis=0) for s in SIDES) * rec.dt
        impulse += rec.mass * g * (rec.t[i1] - rec.t[i0])
        p = [_momentum(model, data, rec, i) for i in (i0, i1)]
        weight_time = rec.mass * 9.81 * (t1 - t0)
        assert np.linalg.norm(p[1] - p[0] - impulse) < 0.01 * weight_time


@pytest.mark.parametrize("direction", ["forward", "left"])
def test_the_walk_survives_a_push_of_15_percent_body_weight(male, male_cycle, direction):
    """A 0.1 s push of 15 % of body weight at the pelvis, at a mid-stance of the third stride,
    forward or sideways: the body walks on (four steps more) without a fall, and over the
    push the body's momentum changes by the push's impulse plus the ground's and gravity's
    (within 1 % of m g T: the push is 15 % of it)."""
    push = pelvis_push(male, male_cycle, 0.15, direction)
    assert np.linalg.norm(push.force) == pytest.approx(0.15 * male.mass * 9.81)
    walk = walk_on_ground(male, steps=10, cycle=male_cycle, pushes=[push])
    assert walk.completed, walk.trajectory.metadata["message"]
    rec, model = walk.record, male.model
    data = model.createData()
    i0, i1 = np.searchsorted(rec.t, [push.start - 0.05, push.start + push.duration + 0.05])
    ground = sum(rec.force[s][i0:i1].sum(axis=0) for s in SIDES) * rec.dt
    gravity = rec.mass * model.gravity.linear * (rec.t[i1] - rec.t[i0])
    pushed = np.array(push.force) * push.duration
    p = [_momentum(model, data, rec, i) for i in (i0, i1)]
    error = np.linalg.norm(p[1] - p[0] - ground - gravity - pushed)
    assert error < 0.01 * rec.mass * 9.81 * (rec.t[i1] - rec.t[i0]), error
    with pytest.raises(HumanoidError, match="direction"):
        pelvis_push(male, male_cycle, 0.15, "up")


def test_joint_moments_are_the_plants_torques(male):
    """The recorder's inverse dynamics (RNEA of the step's acceleration and ground forces)
    gives back the torque at each knee (a hinge about the thigh's lateral axis): the
    controller's plus the passive moment of the knee's range when it is at a stop (the net
    joint moment, as a gait lab's inverse dynamics reports it): the knee extensor moment is
    minus that torque, to 1e-6 of its size."""
    torques = []

    class Torques:
        def observe(self, sim, k, t, q, v, step):
            passive = sim.ground_step.limit_generalized / sim.scene.dt
            torques.append(step.torque + passive)

    from humanoid.simulation import Simulation
    from humanoid.walking import gait

    original = Simulation.run

    def run(self, *args, monitors=(), **kw):  # Torques observes after the walk's recorder
        return original(self, *args, monitors=[*monitors, Torques()], **kw)

    Simulation.run = run
    try:
        walk = walk_on_ground(male, steps=2)
    finally:
        Simulation.run = original
    assert walk.completed
    tau = np.array(torques)[: len(walk.record.t)]
    for side in SIDES:
        chain = gait.leg_chains(male)[side]
        iv = male.model.joints[chain.knee].idx_v
        moment = walk.record.kinetics[side][:, 2]
        size = np.abs(tau[:, iv]).max()
        assert size > 20.0  # [N m] a real load, not a trivial zero
        np.testing.assert_allclose(moment, -tau[:, iv], atol=1e-6 * size)


def _synthetic_record(h, speed=1.3, period=1.1, stance=0.6, duration=6.0, dt=1e-3):
    """A walk drawn by hand: the body glides at ``speed``, each foot loaded (0.6 BW) for
    ``stance`` of every cycle, the right from 0.1 s, the left half a cycle later; heel only
    for the first tenth of a stance, toe only for the last."""
    t = np.arange(0.0, duration, dt)
    q = np.tile(h.standing_configuration(), (len(t), 1))
    q[:, 0] += speed * t
    weight = h.mass * 9.81
    force, heel, toe = {}, {}, {}
    for s, start in (("right", 0.1), ("left", 0.1 + period / 2)):
        u = ((t - start) % period) / period
        on = (t >= start) & (u < stance)
        force[s] = np.zeros((len(t), 3))
        force[s][on, 2] = 0.6 * weight
        heel[s] = on & (u < 0.9 * stance)
        toe[s] = on & (u > 0.1 * stance)
    return GaitRecord(t, q, np.zeros((len(t), h.model.nv)), force,
                      cop={s: np.zeros((len(t), 2)) for s in SIDES}, heel=heel, toe=toe,
                      slip={s: np.zeros((len(t), 2)) for s in SIDES},
                      kinetics={s: np.zeros((len(t), 7)) for s in SIDES}, mass=h.mass,
                      dt=dt)  # fmt: skip


def test_events_and_spatiotemporal_values_of_a_walk_drawn_by_hand(male):
    """Heel strikes and toe offs from the vertical force, and the values a gait lab derives from
    them, on a record whose answers are known: speed 1.3 m/s, 1.1 s cycles, 60 % stance."""
    rec = _synthetic_record(male)
    a = analyse(male, rec, skip=0.5)
    np.testing.assert_allclose(a.events["right"]["strike"][:3], [0.1, 1.2, 2.3], atol=2e-3)
    np.testing.assert_allclose(a.events["right"]["off"][:2], [0.76, 1.86], atol=2e-3)
    s = a.summary
    assert s["speed"] == pytest.approx(1.3, abs=5e-3)
    assert s["cadence"] == pytest.approx(120 / 1.1, abs=0.3)
    assert s["stride_length"] == pytest.approx(1.43, abs=5e-3)
    assert s["step_length"] == pytest.approx(0.715, abs=5e-3)
    assert s["stance"] == pytest.approx(0.6, abs=3e-3)
    assert s["double_support"] == pytest.approx(0.2, abs=3e-3)
    assert s["heel_to_toe"] == 1.0
    # the body stands upright: its angles stay at the standing zero; the feet carry 0.6 BW
    assert np.abs(a.mean("knee_flexion")).max() < 1e-9
    # (low-passed at 15 Hz with zero lag: a step of force is half-way at its edge, and flat
    # 50 ms on)
    fz = a.mean("grf_vertical")
    np.testing.assert_allclose(fz[(PERCENT > 10) & (PERCENT < 50)], 0.6, atol=1e-3)
    assert fz[0] == pytest.approx(0.3, abs=0.03)
    assert np.abs(fz[(PERCENT > 70) & (PERCENT < 90)]).max() < 1e-3


def test_a_stance_the_record_ends_in_is_not_analysed(male):
    """A record that stops mid-stance, its last 10 ms a rigid contact's zero-force samples (a
    gap the hysteresis reads as a lift-off): that stance is not complete and is not judged (CI
    once saw such a stance reported without its foot flat)."""
    rec = _synthetic_record(male, duration=5.7)  # the right foot strikes at 5.6 s
    assert rec.force["right"][-11, 2] > 0
    rec.force["right"][-10:, 2] = 0.0
    times = [f["time"] for f in analyse(male, rec, skip=0.5).feet["right"]]
    assert times and max(times) < 5.0, times


def test_the_gait_report_draws_the_curves_over_the_norms(male, tmp_path):
    """The report's figure is written; its table marks a value outside the adult norm."""
    a = analyse(male, _synthetic_record(male), skip=0.5)
    rows = {label: (value, ok) for label, value, _, ok in gait_table(a)}
    assert rows["cadence"][1] is True  # 109 steps/min
    assert rows["vertical GRF, 1st peak"][1] is False  # 0.6 BW
    path = plot_gait_report(a, tmp_path / "report.png")
    assert path.stat().st_size > 50_000
    assert "double support" in format_gait_table(a)


def test_the_walk_command_walks_the_persons_optimised_cycle(tmp_path, capsys):
    """Plain ``humanoid walk`` walks the body's shipped optimised cycle (no casadi needed): six
    steps of the male body with toes, measured, written, reported."""
    from humanoid.cli import main

    urdf = tmp_path / "male.urdf"
    assert main(["build", "--height", "1.75", "--mass", "75", "--sex", "male", "--toes",
                 "-o", str(urdf)]) == 0  # fmt: skip
    out, report = tmp_path / "walk.npz", tmp_path / "report.png"
    code = main(["walk", "--model", str(urdf), "--steps", "6", "-o", str(out), "--report",
                 str(report), "--quiet"])  # fmt: skip
    text = capsys.readouterr().out
    assert code == 0, text
    assert out.is_file() and report.is_file()
    speed = next(line for line in text.splitlines() if line.startswith("speed"))
    assert "1.3" in speed or "1.4" in speed, speed  # the cycle's 1.38 m/s


def test_a_walk_without_a_stored_cycle_or_casadi_says_what_to_install(tmp_path):
    """No cycle shipped or cached at that speed, and no casadi to optimise one: one line that
    says so (exit 2), not a traceback."""
    import subprocess
    import sys

    code = ("import sys; sys.modules['casadi'] = None; from humanoid.cli import main; "
            "sys.exit(main(['walk', '--speed', '0.93', '--steps', '2', '--quiet', '-o', "
            f"{str(tmp_path / 'w.npz')!r}]))")  # fmt: skip
    env = {"HUMANOID_CACHE": str(tmp_path), "PATH": "/usr/bin:/bin"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       timeout=120)  # fmt: skip
    assert r.returncode == 2, r.stderr
    assert "optimal-control extra" in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert "0.93 m/s" in r.stderr


def test_a_cycle_stored_under_another_objective_revision_is_not_found(tmp_path, monkeypatch):
    """A user's cache from an older objective is not reused: only the objectives' current
    revision is found (the package's cycles, and the cache's in its place)."""
    import shutil

    from humanoid.optimal.coordinates import build_ocp_model
    from humanoid.optimal.cycle import REVISION, body_key, default_speed, gait_file, stored

    monkeypatch.setenv("HUMANOID_CACHE", str(tmp_path))
    h = hm.load("adult_male")
    om = build_ocp_model(h)
    speed = default_speed(h)
    shipped = stored(om, "tracking")[speed]
    assert shipped.name == gait_file(om, speed, "tracking")
    (tmp_path / "gaits").mkdir()
    old = f"{body_key(om)}-tracking-r{REVISION - 1}-093.npz"
    shutil.copy(shipped, tmp_path / "gaits" / old)
    assert 0.93 not in stored(om, "tracking")
    shutil.copy(shipped, tmp_path / "gaits" / gait_file(om, 0.93, "tracking"))
    assert 0.93 in stored(om, "tracking")


def test_a_transition_or_turn_is_found_only_for_its_own_cycle(tmp_path, monkeypatch):
    """The shipped start, stop and 2 m turn of the male cycle are found for it, and not for
    another body's cycle or for another cycle of the same body at that speed (a cache the
    cycle was optimised again into): such a file is skipped, not walked."""
    import dataclasses

    from humanoid.optimal.cycle import (
        KINDS,
        load_transition,
        load_turn,
        stored,
        stored_gait,
        stored_transition,
        stored_turn,
        transition_file,
        turn_file,
    )  # fmt: skip

    monkeypatch.setenv("HUMANOID_CACHE", str(tmp_path))
    male = stored_gait(hm.load("adult_male"))
    female = stored_gait(hm.load("adult_female"))
    for kind in KINDS:
        assert stored_transition(male, kind).kind == kind
    assert stored_turn(male, 2.0).radius == 2.0
    assert stored_turn(male, 3.0) is None  # not shipped
    assert sorted(stored(male.om, "tracking")) == [0.8, 1.0, 1.2, 1.38, 1.6, 1.8]  # gaits only
    path = next(p for p in stored(male.om, "tracking").values()).parent
    with pytest.raises(HumanoidError, match="another body"):
        load_transition(path / transition_file(male, "start"), female)
    # the same body, its cycle optimised again (here: moved 1 mm)
    x = male.solution.x.copy()
    x[:, 0] += 1e-3
    other = dataclasses.replace(male, solution=dataclasses.replace(male.solution, x=x))
    with pytest.raises(HumanoidError, match="another gait cycle"):
        load_transition(path / transition_file(male, "stop"), other)
    with pytest.raises(HumanoidError, match="another gait cycle"):
        load_turn(path / turn_file(male, 2.0), other)
    assert stored_transition(other, "start") is None and stored_turn(other, 2.0) is None
    with pytest.raises(HumanoidError, match="a transition is one of"):
        stored_transition(male, "walk")


def test_the_pelvis_and_the_anterior_force_are_measured_along_the_progression(male):
    """The same walk drawn by hand along x, then turned 90 deg to walk along y, then with its
    pelvis rotated 10 deg and its feet braking along the direction of travel: the pelvis's
    angles and the anterior force are against the direction of progression, not the room's x
    (a curve turns it; the lab's axes follow it)."""
    import dataclasses

    rec = _synthetic_record(male)
    weight = male.mass * 9.81
    for s in SIDES:  # a braking force along the travel, while each foot is loaded
        rec.force[s][rec.force[s][:, 2] > 0, 0] = -0.1 * weight
    turned = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # Rz(90 deg)
    yaw = pin.Quaternion(turned)
    twist = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, 0.0, np.radians(10.0)))
    q = rec.q.copy()
    q[:, :3] = q[:, :3] @ turned.T
    for k in range(len(q)):
        q[k, 3:7] = (yaw * twist * pin.Quaternion(q[k, 6], *q[k, 3:6])).coeffs()
    along_y = dataclasses.replace(rec, q=q, force={s: f @ turned.T for s, f in rec.force.items()})
    a, b = analyse(male, rec, skip=0.5), analyse(male, along_y, skip=0.5)
    assert b.summary["speed"] == pytest.approx(a.summary["speed"], abs=1e-9)
    np.testing.assert_allclose(b.mean("grf_anterior"), a.mean("grf_anterior"), atol=1e-9)
    assert a.mean("grf_anterior").min() == pytest.approx(-0.1, abs=5e-3)  # (the filter)
    # the pelvis: 10 deg of rotation, none of it in tilt or obliquity (the room's axes would
    # read the walk's 90 deg turn into all three)
    np.testing.assert_allclose(b.mean("pelvis_rotation", "right"), 10.0, atol=1e-6)
    np.testing.assert_allclose(b.mean("pelvis_rotation", "left"), -10.0, atol=1e-6)
    np.testing.assert_allclose(b.mean("pelvis_tilt"), a.mean("pelvis_tilt"), atol=1e-6)
    np.testing.assert_allclose(b.mean("pelvis_obliquity"), a.mean("pelvis_obliquity"), atol=1e-6)


def test_a_peak_is_each_sides_averaged_not_the_peak_of_the_sides_mean_curve():
    """A gait lab reports each limb's peaks: two sides braking at 0.16 and 0.15 BW, at 10 and
    16 % of the cycle, brake at 0.155 BW on average; the peak of their mean curve is lower
    (the male's turn: 0.11 BW from per-side peaks of 0.165 and 0.151)."""
    from collections import defaultdict

    from humanoid.walking.gait import GaitAnalysis

    def curves(depth, at):
        c = defaultdict(lambda: np.zeros((1, len(PERCENT))))
        c["grf_anterior"] = -depth * np.exp(-(((PERCENT - at) / 3.0) ** 2))[None]
        c["grf_vertical"] = np.where(PERCENT < 60, 1.0, 0.0)[None]
        return c

    a = GaitAnalysis(
        events={}, cycles={"left": [(0.0, 1.0)], "right": [(0.0, 1.0)]},
        curves={"left": curves(0.16, 10.0), "right": curves(0.15, 16.0)},
        table={"stance": [0.6], "double_support": [0.2]}, feet={"left": [], "right": []},
        dimensionless_speed=0.45, mass=75.0,
    )  # fmt: skip
    s = a.summary
    assert abs(s["braking"] - 0.155) < 1e-3, s["braking"]
    assert -a.mean("grf_anterior").min() < 0.13  # the sides' mean curve's peak
