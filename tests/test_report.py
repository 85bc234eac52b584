"""``humanoid report`` of a person's own trial (humanoid.walking.trial), checked on a trial made
from the toolkit's own simulated walk, whose events and gait analysis are known exactly.

The trial is written as a lab's pipeline writes it: the coordinates at 100 Hz (``humanoid ik``'s
writer: coordinates_table, write_storage), the feet's loads at 1 kHz (``humanoid loads``'s
writer) and the generalised forces of the walk's inverse dynamics at 1 kHz (``humanoid id``'s:
inverse_dynamics of the walk's every step with backward differences and no filter, which gives
back the plant's torques, then generalized_forces_table): so the report's angles, moments and
forces must be the simulated walk's own analysis (GaitAnalysis) to rounding, and its powers
within what the 100 Hz coordinates' velocities allow.
"""

from __future__ import annotations

import math
import re
import types
import warnings

import numpy as np
import pytest

import humanoid as hm
from humanoid.cli import main
from humanoid.model import SIDES
from humanoid.motion.coordinates import generalized_forces, generalized_forces_table
from humanoid.motion.export import write_opensim
from humanoid.motion.inverse_dynamics import inverse_dynamics
from humanoid.motion.loads import Load, write_loads
from humanoid.motion.storage import MotionFileError, Table, read_storage, write_storage
from humanoid.walking.gait import EVENT_ON, analyse, walk_on_ground
from humanoid.walking.trial import (
    PERCENT,
    TrialError,
    TrialWarning,
    analyse_trial,
    force_contacts,
    read_trial,
)

ANGLES = ("hip_flexion", "hip_adduction", "hip_rotation", "knee_flexion", "ankle_dorsiflexion",
          "pelvis_tilt", "pelvis_obliquity", "pelvis_rotation")  # fmt: skip
SAGITTAL = ("hip_extension_moment", "knee_extension_moment", "ankle_plantarflexion_moment")
POWERS = ("hip_power", "knee_power", "ankle_power")


@pytest.fixture(scope="module")
def walk():
    """Five steps of the male body at its free speed, every step recorded (about 15 s), its
    analysis from its first strike (two left cycles, one right), and its trial's files."""
    h = hm.load("adult_male")
    w = walk_on_ground(h, steps=5, record_rate=1000.0)
    assert w.completed
    return w, analyse(w.body, w.record, skip=0.0)


@pytest.fixture(scope="module")
def files(walk, tmp_path_factory):
    w, _ = walk
    h, rec, traj = w.body, w.record, w.trajectory
    out = tmp_path_factory.mktemp("trial")
    ks = np.arange(0, len(rec.t), 10)  # the coordinates at 100 Hz, the record's own samples
    run = types.SimpleNamespace(t=rec.t[ks], q=rec.q[ks], forces={})
    motion = write_opensim(h, run, out / "walk_ik.mot")[0]
    loads = [Load.from_wrench(s, traj.t, traj.forces[f"ground_{s}"]) for s in SIDES]
    grf = write_loads(out / "walk_grf.mot", loads, name="walk ground reaction")
    r = inverse_dynamics(h, traj.t, traj.q, loads, cutoff=None, velocity="backward")
    table = generalized_forces_table(h, r.time, r.q, r.tau)
    table.name = "Inverse Dynamics"
    moments = write_storage(out / "walk_id.sto", table)
    return types.SimpleNamespace(motion=motion, grf=grf, moments=moments, dir=out)


@pytest.fixture(scope="module")
def trial(walk, files):
    with warnings.catch_warnings():
        warnings.simplefilter("error", TrialWarning)  # a complete trial leaves nothing out
        return read_trial(walk[0].body, files.motion, files.moments, files.grf)


@pytest.fixture(scope="module")
def same_events(walk, files):
    """The trial read at its analysis's own contact thresholds (2 % of body weight, released
    at half): its events are the analysis's, sample for sample. (At the plates' 20 N they are
    within a sample, and one sample off moves a cycle's curves by up to 0.15 deg.)"""
    h = walk[0].body
    weight = h.mass * float(np.linalg.norm(h.model.gravity.linear))
    with warnings.catch_warnings():
        warnings.simplefilter("error", TrialWarning)
        return read_trial(h, files.motion, files.moments, files.grf, threshold=EVENT_ON * weight)


def test_the_report_finds_the_walks_cycles_and_heel_strikes(walk, trial):
    """Events from the loads (20 N, the force plates'): the walk's own heel strikes and toe
    offs (its analysis's, at 2 % of body weight) to one sample of the loads (1 ms), hence its
    cycles: two left, one right."""
    _, ref = walk
    a = trial.analysis
    assert trial.events == {"left": "loads", "right": "loads"}
    assert trial.kinetics and trial.forces
    for s in SIDES:
        assert len(a.cycles[s]) == len(ref.cycles[s]) == {"left": 2, "right": 1}[s]
        for key in ("strike", "off"):
            np.testing.assert_allclose(a.events[s][key], ref.events[s][key], atol=1e-3 + 1e-9)
        np.testing.assert_allclose(a.cycles[s], ref.cycles[s], atol=1e-3 + 1e-9)


def test_the_curves_are_the_simulated_walks_analysis(walk, same_events):
    """Every cycle's curves over 101 samples; at every other one (the norms' 51) they are the
    walk's GaitAnalysis: angles to 1e-6 deg (the same samples and definitions: a cycle sampled
    one sample off is degrees off), sagittal moments to 1e-6 N m/kg (per kg: a moment not
    divided by the mass, or twice, is 75 times off), the ground reaction to 1e-5 BW, the hip
    abductor moment to 5e-3 N m/kg (the pelvis's axes from the 100 Hz motion interpolated onto
    the moments' 1 kHz), the powers to 0.25 W/kg RMS and 1.5 W/kg at most (ranges 6-16 W/kg:
    the velocities are the 100 Hz coordinates' central differences, the simulation's its own
    at every step; they differ most at the impacts)."""
    _, ref = walk
    a = same_events.analysis
    assert np.array_equal(a.percent, PERCENT) and len(PERCENT) == 101
    np.testing.assert_array_equal(a.percent[::2], ref.percent)

    def check(name, atol, rms=None):
        for s in SIDES:
            mine, theirs = a.curves[s][name], ref.curves[s][name]
            assert mine.shape == (len(ref.cycles[s]), 101), (name, s, mine.shape)
            d = mine[:, ::2] - theirs
            assert np.abs(d).max() <= atol, (name, s, np.abs(d).max())
            if rms is not None:
                assert np.sqrt(np.mean(d**2)) <= rms, (name, s, np.sqrt(np.mean(d**2)))

    for name in ANGLES:
        check(name, 1e-6)
    for name in SAGITTAL:
        check(name, 1e-6)
    check("hip_abduction_moment", 5e-3)
    check("grf_vertical", 1e-5)
    check("grf_anterior", 1e-5)
    for name in POWERS:
        check(name, 1.5, rms=0.25)
    # the left side's two cycles: mean and SD over them; the right's one: SD zero
    np.testing.assert_allclose(a.mean("knee_flexion", "left"), a.curves["left"]["knee_flexion"]
                               .mean(axis=0))  # fmt: skip
    assert np.all(a.sd("knee_flexion", "right") == 0.0)
    assert a.sd("knee_flexion", "left").max() > 0.1
    # per kg of a physiological size: the ankle's push-off
    assert 1.5 < a.mean("ankle_plantarflexion_moment", "right").max() < 3.0


def test_the_moments_are_per_kg_of_the_subjects_mass(walk, files, trial):
    """Given a mass twice the body's, the moments and powers halve; the angles, forces (in body
    weights of the same mass: halved too) and events stay."""
    w, _ = walk
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TrialWarning)
        heavy = read_trial(w.body, files.motion, files.moments, files.grf, mass=2 * w.body.mass)
    assert heavy.mass == pytest.approx(2 * w.body.mass)
    for s in SIDES:
        for name in (*SAGITTAL, *POWERS):
            half = 0.5 * trial.analysis.curves[s][name]
            np.testing.assert_allclose(heavy.analysis.curves[s][name], half, atol=1e-12)
        np.testing.assert_array_equal(heavy.analysis.curves[s]["knee_flexion"],
                                      trial.analysis.curves[s]["knee_flexion"])  # fmt: skip
        assert heavy.analysis.events[s] == trial.analysis.events[s]


def test_the_spatiotemporal_table_per_side(walk, same_events):
    """Each side's values are its own cycles' (the step length of a side: its heel strike's
    distance ahead of the other foot), the same as the walk's analysis overall."""
    from humanoid.walking.report import format_trial_table, trial_table

    _, ref = walk
    a = same_events.analysis
    for key in ("speed", "cadence", "stride_length", "stance", "double_support", "step_length"):
        mine = np.concatenate([a.side_table(s)[key] for s in SIDES])
        np.testing.assert_allclose(np.sort(mine), np.sort(ref.table[key]), atol=2e-3)
    left, right = a.side_table("left"), a.side_table("right")
    assert len(left["cadence"]) == 2 and len(right["cadence"]) == 1
    # the left's steps end at the left strikes (within the right cycle): one of them
    assert len(left["step_length"]) == 1 and len(right["step_length"]) == 2
    rows = {r[0]: r for r in trial_table(a)}
    assert set(rows) == {"speed", "cadence", "step length", "stride length", "stance",
                         "double support"}  # fmt: skip
    assert rows["cadence"][4] is True and rows["cadence"][5] is True  # 114 steps/min
    text = format_trial_table(a)
    assert "left" in text and "right" in text and "adult norm" in text


def test_kinematic_events_without_loads_are_within_two_frames(walk, files):
    """The coordinates alone: the events from the feet's motion, within two frames (20 ms) of
    the force's; the same cycles; the warnings name what is missing."""
    w, ref = walk
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TrialWarning)
        t = read_trial(w.body, files.motion)
    said = " | ".join(str(x.message) for x in caught)
    assert "walk_ik.mot: no moments: kinematics only" in said
    assert "no left foot events or loads" in said and "no right foot events" in said
    assert t.events == {"left": "kinematics", "right": "kinematics"}
    assert not t.kinetics and not t.forces
    a = t.analysis
    for s in SIDES:
        assert len(a.cycles[s]) == len(ref.cycles[s])
        for key in ("strike", "off"):
            assert len(a.events[s][key]) == len(ref.events[s][key])
            np.testing.assert_allclose(a.events[s][key], ref.events[s][key], atol=0.02 + 1e-9)
        assert len(a.curves[s]["knee_power"]) == 0  # (no moments)


def test_c3d_events_come_first_and_out_of_range_ones_are_named(walk, files):
    """Events (as read_events gives a C3D's) are used before the loads' (here 5 ms late);
    one outside the motion's times and one that is no foot's are left out, named."""
    w, ref = walk
    table = read_storage(files.motion)
    from humanoid.motion.coordinates import configurations

    time, q, _ = configurations(w.body, table)
    events = [(x + 0.005, s.capitalize(), "Foot Strike") for s in SIDES
              for x in ref.events[s]["strike"]]  # fmt: skip
    events += [(x + 0.005, s.capitalize(), "Foot Off") for s in SIDES for x in ref.events[s]["off"]]
    events += [(9.0, "Left", "Foot Strike"), (1.0, "General", "Event")]
    loads = [Load.from_wrench(s, w.trajectory.t, w.trajectory.forces[f"ground_{s}"]) for s in SIDES]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TrialWarning)
        t = analyse_trial(w.body, time, q, loads=loads, events=sorted(events), source="e.c3d")
    said = " | ".join(str(x.message) for x in caught)
    assert "1 events outside the motion's 0.000-2.720 s left out: Left Foot Strike 9.000 s" in said
    assert "no foot strike or foot off left out: General Event 1.000 s" in said
    assert t.events == {"left": "C3D events", "right": "C3D events"}
    for s in SIDES:
        np.testing.assert_allclose(t.analysis.events[s]["strike"],
                                   np.array(ref.events[s]["strike"]) + 0.005)  # fmt: skip
        assert len(t.analysis.cycles[s]) == len(ref.cycles[s])


def test_a_side_without_a_full_cycle_is_said(walk, files):
    """The first 1.5 s: the left has one cycle, the right none (one strike): said, and its
    curves are empty."""
    w, ref = walk
    from humanoid.motion.coordinates import configurations

    time, q, _ = configurations(w.body, read_storage(files.motion))
    keep = time <= 1.5
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TrialWarning)
        t = analyse_trial(w.body, time[keep], q[keep], read_storage(files.moments),
                          [Load.from_wrench(s, w.trajectory.t,
                                            w.trajectory.forces[f"ground_{s}"]) for s in SIDES],
                          source="short.mot")  # fmt: skip
    said = " | ".join(str(x.message) for x in caught)
    found = re.search(r"short\.mot: the right side has fewer than one full cycle \(heel strikes "
                      r"at ([0-9.]+) s, from loads\)", said)  # fmt: skip
    assert found, said
    assert float(found[1]) == pytest.approx(ref.events["right"]["strike"][0], abs=5e-3)
    assert len(t.analysis.cycles["left"]) == 1 and len(t.analysis.cycles["right"]) == 0
    assert len(t.analysis.curves["right"]["knee_flexion"]) == 0
    assert len(t.analysis.curves["left"]["knee_power"]) == 1  # (the moments cover it)


def test_plates_that_catch_one_step_per_foot_leave_the_others_to_the_motion(walk, files):
    """A lab's two plates, one step on each: the other steps' events come from the motion,
    moved by the plates' own edges where both saw a stance; every cycle has its angles, the
    moments and forces only the cycles whose stance was on a plate (said)."""
    from humanoid.motion.coordinates import configurations

    w, ref = walk
    time, q, _ = configurations(w.body, read_storage(files.motion))
    loads = []
    for s in SIDES:  # (each foot's load zero but for its first whole stance)
        on = ref.events[s]["strike"][0]
        off = min(x for x in ref.events[s]["off"] if x > on)
        f = w.trajectory.forces[f"ground_{s}"].copy()
        f[(w.trajectory.t < on - 0.01) | (w.trajectory.t > off + 0.01)] = 0.0
        loads.append(Load.from_wrench(s, w.trajectory.t, f))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TrialWarning)
        t = analyse_trial(w.body, time, q, read_storage(files.moments), loads, source="p.c3d")
    said = " | ".join(str(x.message) for x in caught)
    for s in SIDES:
        assert t.events[s].startswith("loads (") and "from kinematics)" in t.events[s]
        a = t.analysis
        assert len(a.cycles[s]) == len(ref.cycles[s]) >= 1
        for key in ("strike", "off"):
            np.testing.assert_allclose(a.events[s][key], ref.events[s][key], atol=0.02 + 1e-9)
        assert len(a.curves[s]["knee_flexion"]) == len(ref.cycles[s])
        assert len(a.curves[s]["grf_vertical"]) == 1
    assert "cycles without ground forces (the foot on no plate" in said


def test_merged_contacts_move_the_motions_edges_by_the_plates():
    """Where a plate and the motion both saw a stance, the motion's other stances are moved
    by the mean difference of their edges; a stance the plate saw replaces the motion's."""
    from humanoid.walking.trial import merged_contacts

    loaded = [(1.00, 1.60)]
    moving = [(-np.inf, 0.45), (0.96, 1.62), (2.06, 2.64)]
    out, added = merged_contacts(loaded, moving)
    assert added == 2
    assert out[0][0] == -np.inf and out[0][1] == pytest.approx(0.43)
    assert out[1] == (1.00, 1.60)
    assert out[2] == pytest.approx((2.10, 2.62))
    assert merged_contacts([], moving) == (moving, 3)


def test_the_report_command_writes_the_figure_and_prints_the_table(walk, files, capsys):
    """``humanoid report`` end to end, on the default body (its toes free, at zero): the
    events it prints are the walk's (its cycles within a sample, printed to the ms)."""
    png = files.dir / "report.png"
    argv = ["report", str(files.motion), "--moments", str(files.moments), "--loads",
            str(files.grf), "--mass", "75", "-o", str(png)]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert png.stat().st_size > 100_000
    _, ref = walk
    for side, said in (("left", "3 strikes, 2 offs"), ("right", "2 strikes, 3 offs")):
        line = re.search(rf"^{side} +events from loads: {said}; cycles (.*) s$", out, re.M)
        assert line, out
        printed = [[float(x) for x in c.split("-")] for c in line.group(1).split(", ")]
        np.testing.assert_allclose(printed, ref.cycles[side], atol=1e-3 + 5e-4)
    assert "kinetics     walk_id.sto, per kg of 75.0 kg" in out
    assert "double support" in out and "adult norm" in out and f"report       {png}" in out


def _storage(path, labels, rows, header=("version=1", "inDegrees=yes")):
    lines = ["trial", *header, "endheader", "\t".join(labels)]
    lines += ["\t".join(str(x) for x in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_bad_input_is_one_line_naming_the_file(files, tmp_path, capsys):
    """A .mot without a time column, moments given as the motion, coordinates given as
    moments, moments of another trial's times: exit 2, one line naming the file and what is
    wrong, no traceback."""
    no_time = _storage(tmp_path / "no_time.mot", ["frame", "hip_flexion_r"], [[0, 1.0], [1, 2.0]])
    table = read_storage(files.moments)
    later = Table(table.time + 100.0, table.labels, table.data, False, source="later")
    shifted = write_storage(tmp_path / "later_id.sto", later)
    cases = [
        (["report", str(no_time)], "no_time.mot:5: the first column must be 'time', got 'frame'"),
        (["report", str(files.moments)], "walk_id.sto: its columns are generalised forces"),
        (["report", str(files.motion), "--moments", str(files.motion)],
         "walk_ik.mot: no generalised forces (columns like hip_flexion_r_moment): not a "
         "moments file"),
        (["report", str(files.motion), "--moments", str(shifted)],
         "later_id.sto: its times (100.000-102.730 s) and the motion's (0.000-2.720 s) do not "
         "overlap"),
        (["report", str(files.motion), "--events", str(files.grf)],
         "walk_grf.mot: events are read from a C3D file's EVENT group"),
    ]  # fmt: skip
    for argv, message in cases:
        assert main([*argv, "-o", str(tmp_path / "r.png")]) == 2, argv
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, (argv, err)
        assert err.count("\n") == 1
    assert issubclass(TrialError, MotionFileError)


def test_a_moments_file_without_the_legs_moments_is_refused(walk, files, tmp_path):
    table = read_storage(files.moments)
    keep = [i for i, x in enumerate(table.labels) if not x.startswith("knee_angle")]
    partial = Table(table.time, [table.labels[i] for i in keep], table.data[:, keep], False,
                    source="partial.sto")  # fmt: skip
    time, q = walk[0].record.t[::10], walk[0].record.q[::10]
    with pytest.raises(TrialError, match="partial.sto: no column knee_angle_l_moment, "
                       "knee_angle_r_moment"):  # fmt: skip
        analyse_trial(walk[0].body, time, q, partial)


def test_generalized_forces_invert_the_table():
    """The .sto's moments back to the body's joint moments, to rounding, for both kinds of
    map (Rajagopal's knee flexion positive, gait2392's negative), ball joints at random
    turns."""
    import pinocchio as pin

    rng = np.random.default_rng(1)
    h = hm.load("adult_male")
    q = np.tile(h.standing_configuration(), (20, 1))
    for qi in q:  # every ball joint turned at random (up to 60 degrees), every hinge too
        for jm in h.model.joints[2:]:
            if jm.nq == 4:
                turn = pin.exp3(rng.normal(size=3) * 0.6)
                qi[jm.idx_q : jm.idx_q + 4] = pin.Quaternion(turn).coeffs()
            else:
                qi[jm.idx_q] = rng.uniform(-0.8, 0.8)
    tau = rng.normal(scale=40.0, size=(len(q), h.nv))
    time = np.arange(len(q)) * 0.01
    for cmap in ("rajagopal", "gait2392"):
        back = generalized_forces(h, q, generalized_forces_table(h, time, q, tau, cmap), cmap)
        assert np.isnan(back[:, :6]).all()  # (the root's residuals are not joint moments)
        legs = ~np.isnan(back[0])
        assert legs.sum() >= h.nv - 6 - 2  # every joint but the toes (no map column)
        np.testing.assert_allclose(back[:, legs], tau[:, legs], atol=1e-9)


def test_force_contacts_ignore_noise_and_bounces_and_keep_the_raw_edges():
    """A noisy plate (+-6 N) with a 20 ms heel bounce: one contact, from the raw force's first
    rise above 20 N to its last fall below 10 N, not the filtered force's (which spread)."""
    t = np.arange(0.0, 1.5, 1e-3)
    fz = np.where((t >= 0.3) & (t < 0.95), 700.0, 0.0)
    fz[(t >= 0.31) & (t < 0.33)] = 0.0  # the bounce
    fz = fz + np.random.default_rng(2).uniform(-6.0, 6.0, len(t))
    contacts = force_contacts(t, fz)
    assert len(contacts) == 1
    ((on, off),) = contacts
    assert on == pytest.approx(0.3, abs=1e-9) and off == pytest.approx(0.949, abs=1e-9)
    assert force_contacts(t, np.where(t < 0.5, 700.0, 0.0))[0][0] == -math.inf


def test_a_c3d_of_markers_and_events_is_reported_through_inverse_kinematics(
    walk, files, capsys, monkeypatch
):
    """``humanoid report trial.c3d``: the toolkit's markers on the walk (100 Hz, millimetres,
    as a lab's C3D) and its events in the EVENT group, no force plates: inverse kinematics on
    the default body, events from the file, kinematics only (said); its knee and hip curves
    the walk's within 1 deg (markers exact: the fit's error)."""
    import ezc3d

    from humanoid.motion.markers import default_markers, marker_positions

    w, ref = walk
    rec = w.record
    ks = np.arange(0, len(rec.t), 10)
    markers = default_markers(w.body)
    where = marker_positions(w.body, rec.q[ks], markers)  # (frames, markers, 3) [m]
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    c["parameters"]["POINT"]["RATE"]["value"] = [100]
    c["parameters"]["POINT"]["LABELS"]["value"] = tuple(markers)
    points = np.ones((4, len(markers), len(ks)))
    points[:3] = np.transpose(where, (2, 1, 0)) * 1000.0
    c["data"]["points"] = points
    for s in SIDES:
        for key, label in (("strike", "Foot Strike"), ("off", "Foot Off")):
            for t in ref.events[s][key]:
                c.add_event([0, float(t)], context=s.capitalize(), label=label)
    path = files.dir / "walk.c3d"
    c.write(str(path))
    png = files.dir / "c3d.png"
    from humanoid.walking import report

    drawn = []
    original = report.plot_trial_report
    monkeypatch.setattr(
        report,
        "plot_trial_report",
        lambda trial, *a, **k: drawn.append(trial) or original(trial, *a, **k),
    )
    assert main(["report", str(path), "-o", str(png)]) == 0
    out = capsys.readouterr().out
    for s in SIDES:  # the walk's own events, written into the C3D and read back
        ev = ref.events[s]
        cycles = ", ".join(f"{t0:.3f}-{t1:.3f}" for t0, t1 in ref.cycles[s])
        assert (f"{s:<12} events from C3D events: {len(ev['strike'])} strikes, "
                f"{len(ev['off'])} offs; cycles {cycles} s") in out, out  # fmt: skip
    assert [len(ref.cycles[s]) for s in SIDES] == [2, 1]  # the five steps' (left, right)
    assert "kinetics     none: kinematics only (no force plates)" in out
    assert "FORCE_PLATFORM:USED is 0: no force plates" in out and png.exists()
    (t,) = drawn
    for s in SIDES:
        for name in ("hip_flexion", "knee_flexion"):
            d = t.analysis.curves[s][name][:, ::2] - ref.curves[s][name]
            assert np.abs(d).max() < 1.0, (s, name, np.abs(d).max())
