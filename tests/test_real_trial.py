"""The shipped real trials (humanoid/data/trials, OpenSim's, Apache-2.0) through the toolkit.

- ``walking5.c3d`` (Vicon, two AMTI type 2 plates, 2000 Hz): its plates and markers as
  :mod:`humanoid.motion.c3d` and :func:`~humanoid.motion.markers.read_c3d` read them equal
  OpenSim's own export of the file (its C3DFileAdapter test's reference files, in
  tests/data: every 100th analog sample, every 10th marker frame, the lab's Z-up axes, mm and
  N mm) to the precision they are printed with: 8 decimals for the loads, 5 significant
  digits for the markers. The unloaded plates' offset (about -20 N, pulling down) is no
  contact.
- ``subject01`` (gait2354's example subject, 72.6 kg): the default body scaled to its static
  trial (markers placed within 10 mm RMS: measured 0.9 mm), the walk fitted (the legs' markers
  4-14 mm RMS each; the trunk's and arms' 30-60 mm: they were not put on the same places in
  the two trials, which the test shows), its inverse dynamics under the recorded plates (root
  residual force 5.0 % of body weight RMS), and the same through the command line.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from humanoid.data import TRIALS, trial_names, trial_path
from humanoid.motion.c3d import PlateWarning, c3d_loads, read_plates
from humanoid.motion.markers import read_c3d, read_trc
from humanoid.motion.storage import read_storage

REFERENCE = Path(__file__).resolve().parent / "data"
ROOT = Path(__file__).resolve().parent.parent
C3D = TRIALS / "walking5.c3d"
STATIC, WALK = TRIALS / "subject01_static.trc", TRIALS / "subject01_walk1.trc"
GRF = TRIALS / "subject01_walk1_grf.mot"
MASS = 72.6  # [kg] gait2354_Setup_Scale.xml
LEGS = ("Thigh", "Shank", "Heel", "Midfoot", "Toe")


def test_the_trials_are_shipped():
    names = trial_names()
    for f in ("subject01_static.trc", "subject01_walk1.trc", "subject01_walk1_grf.mot",
              "subject01_walk1_grf.xml", "walking5.c3d"):  # fmt: skip
        assert f in names and trial_path(f).is_file()
    assert trial_path("nothing.trc") is None
    for f in ("README.md", "LICENSE-opensim-core-Apache-2.0.txt", "NOTICE-opensim-core.txt"):
        assert (TRIALS / f).is_file()
    pyproject = (Path(__file__).resolve().parent.parent / "pyproject.toml").read_text()
    for ext in ("trc", "mot", "xml", "c3d", "md", "txt"):
        assert f'"data/trials/*.{ext}"' in pyproject  # in the wheel


# -- walking5.c3d against OpenSim's export -------------------------------------------------


def _vectors(table, prefix: str, k: int) -> np.ndarray:
    return np.column_stack([table.column(f"{prefix}{k}_{i}") for i in (1, 2, 3)])


def test_walking5_plates_equal_opensims_export():
    """Forces (N), centres of pressure (mm) and moments about each plate's centre (N mm), lab
    axes (Z up: ours unturned), at OpenSim's rows: equal to its 8 printed decimals (1e-8 of
    its unit: a relative 1e-11 of the 900 N peak). OpenSim computes a centre of pressure from
    the unloaded plate's noise too; ours is NaN outside a contact, so it is compared in the
    contacts (and the forces everywhere)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlateWarning)
        plates = read_plates(C3D)
    grf = read_storage(REFERENCE / "std_walking5_grfs.sto")  # moments about the centre
    cop = read_storage(REFERENCE / "std_cop_walking5_grfs.sto")  # at the centre of pressure
    rows = np.round(grf.time * 2000.0).astype(int)  # every 100th sample and the last
    np.testing.assert_array_equal(cop.time, grf.time)
    assert len(rows) == 90 and rows[-1] == len(plates[0].time) - 1
    printed = 1e-8 + 1e-12  # half a unit of the 8th decimal, each side's rounding
    for k, p in enumerate(plates, start=1):
        np.testing.assert_allclose(p.time[rows], grf.time, rtol=0, atol=1e-12)
        np.testing.assert_allclose(p.centre * 1e3, _vectors(grf, "p", k)[0], atol=1e-4)
        force = p.force[rows]
        np.testing.assert_allclose(force, _vectors(grf, "f", k), rtol=0, atol=printed)
        np.testing.assert_allclose(force, _vectors(cop, "f", k), rtol=0, atol=printed)
        on = p.contact[rows]
        assert on.sum() >= 10
        np.testing.assert_allclose(p.cop[rows][on] * 1e3, _vectors(cop, "p", k)[on], rtol=0,
                                   atol=printed)  # fmt: skip
        free = _vectors(cop, "m", k)[on] * 1e-3
        np.testing.assert_allclose(p.free_moment[rows][on], free, rtol=0, atol=printed * 1e-3)
        about_centre = np.cross(p.cop[rows] - p.centre, force) + p.free_moment[rows]
        np.testing.assert_allclose(about_centre[on] * 1e3, _vectors(grf, "m", k)[on], rtol=0,
                                   atol=printed)  # fmt: skip


def test_walking5_contacts_and_feet():
    """One contact per plate: the unloaded plates' offset (-12 to -27 N, pulling down: no
    zeroing in the file) is not one (it was, by the force's size, before); each goes to the
    foot its markers put there, with no warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlateWarning)
        plates, loads = c3d_loads(C3D)
    spans = [[(round(p.time[a], 4), round(p.time[b - 1], 4)) for a, b in p.contacts()]
             for p in plates]  # fmt: skip
    assert spans == [[(1.9625, 2.4765)], [(2.3815, 2.974)]]
    assert [(x.body, x.name) for x in loads] == [("left", "FP1"), ("right", "FP2")]
    for p in plates:  # out of contact: the offset, pulling down
        idle = p.force[~p.contact, 2]
        assert np.all(idle < 20.0) and -27.0 < np.median(idle) < -12.0
    peak = max(float(p.force[:, 2].max()) for p in plates)
    assert 850.0 < peak < 950.0


def test_walking5_markers_equal_opensims_export():
    """Positions (mm, lab axes) at every 10th frame equal to their 5 printed significant
    digits (to one unit of the 5th: 2 of the 7209 values, 63.39850 and -89.19550, were
    rounded down by the exporter); the gaps (NaN) the same."""
    ours = read_c3d(C3D)
    ref = read_trc(REFERENCE / "std_walking5_markers.trc", y_up=False)
    assert ours.names == ref.names and len(ours.names) == 40
    assert ours.rate == pytest.approx(250.0)
    frames = np.round(ref.time * 250.0).astype(int)
    a, b = ours.positions[frames] * 1e3, ref.positions * 1e3
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
    seen = np.isfinite(b)
    digit = 10.0 ** (np.floor(np.log10(np.abs(b[seen]))) - 4)  # the 5th significant digit
    assert np.all(np.abs(a[seen] - b[seen]) <= digit)
    assert np.mean(np.abs(a[seen] - b[seen]) <= 0.5 * digit + 1e-9) > 0.999


# -- subject01: scale, IK, ID --------------------------------------------------------------


@pytest.fixture(scope="module")
def subject01():
    """(the scale result, the walk's IK, the walk's markers), each made once."""
    from humanoid.model import load
    from humanoid.motion.ik import RangeLimitWarning, UnconstrainedWarning, inverse_kinematics
    from humanoid.motion.scale import ScaleWarning, scale_body

    static = read_trc(STATIC)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ScaleWarning)
        scaled = scale_body(load("adult_male"), static, None, MASS)
    said = " ".join(str(w.message) for w in caught)
    walk = read_trc(WALK)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RangeLimitWarning)  # (the knees straight: reported)
        warnings.simplefilter("ignore", UnconstrainedWarning)  # (the wrists: no markers)
        fit = inverse_kinematics(scaled.body, walk, scaled.marker_set)
    return scaled, fit, walk, said


def test_subject01_scaled_within_10_mm(subject01):
    """The issue's requirement: the placed markers fit the static trial within 10 mm RMS
    (measured: 0.9 mm RMS, 8.6 mm at most, the temples, which moved 15-21 mm in the trial);
    the stature from the markers within 2 % of OpenSim's setup's 1803.4 mm (1.824 m)."""
    r, _, _, said = subject01
    assert r.rms("placed") < 0.01
    assert r.max("placed") < 0.02
    assert r.rms("unscaled") > 0.03  # (scaling is what fitted it)
    assert r.params.mass == MASS
    assert r.height[1] == pytest.approx(1.8034, rel=0.02)
    assert {m.name for m in r.measured} >= {"thigh", "shank", "foot", "trunk", "pelvis_width"}
    assert all(0.85 < f < 1.15 for f in r.factors.values())
    assert "R.Temple" in said and "L.Temple" in said  # (moved in the static trial: said)


def test_subject01_walk_fitted(subject01):
    """The walk on the scaled body: each leg marker (thigh and shank clusters, heel, midfoot,
    toes) within 15 mm RMS (measured 4-14 mm), the pelvis's within 25 mm (15-20 mm), every
    frame's RMS under 35 mm (mean 27 mm): the trunk's and arms' markers (30-61 mm) were not on
    the same places in the static trial, as their distances show: the acromia 342 mm apart
    standing and 419 mm walking, acromion to elbow 281 mm and 315 mm."""
    r, fit, walk, _ = subject01
    static = read_trc(STATIC)
    rms = fit.marker_rms()
    assert len(rms) == 41
    legs = {n: v for n, v in rms.items() if any(w in n for w in LEGS)}
    assert len(legs) == 24 and max(legs.values()) < 0.015, legs
    assert max(rms[n] for n in ("R.ASIS", "L.ASIS", "V.Sacral")) < 0.025
    assert np.nanmax(fit.frame_rms()) < 0.035

    def apart(t, a, b):
        d = t.positions[:, t.names.index(a)] - t.positions[:, t.names.index(b)]
        return float(np.nanmean(np.linalg.norm(d, axis=1)))

    assert apart(static, "R.Acromium", "L.Acromium") == pytest.approx(0.342, abs=0.005)
    assert apart(walk, "R.Acromium", "L.Acromium") == pytest.approx(0.419, abs=0.005)
    assert apart(static, "R.Acromium", "R.Elbow") == pytest.approx(0.281, abs=0.005)
    assert apart(walk, "R.Acromium", "R.Elbow") == pytest.approx(0.315, abs=0.005)
    assert apart(walk, "R.ASIS", "L.ASIS") == pytest.approx(apart(static, "R.ASIS", "L.ASIS"),
                                                            abs=0.003)  # fmt: skip


def test_subject01_inverse_dynamics(subject01):
    """The recorded plates (read as ``humanoid id`` reads them: the .mot and its ExternalLoads
    .xml next to it; ground_ the right foot, 1_ground_ the left): the root residual force
    under 6 % of body weight RMS over the trial (measured 5.0 %; 3.6 % in OpenSim's ID setup's
    0.4-1.6 s) and its moment under 25 N m RMS (16 N m)."""
    from humanoid.motion.commands import read_loads_file
    from humanoid.motion.inverse_dynamics import inverse_dynamics

    r, fit, _, _ = subject01
    loads = read_loads_file(GRF)
    assert [(x.body, x.name) for x in loads] == [("right", "ground_"), ("left", "1_ground_")]
    res = inverse_dynamics(r.body, fit.time, fit.q, loads)
    weight = r.body.mass * 9.81
    assert r.body.mass == pytest.approx(MASS)
    force = np.linalg.norm(res.residual_force, axis=1)
    moment = np.linalg.norm(res.residual_moment, axis=1)
    assert math.sqrt(np.mean(force**2)) / weight < 0.06
    window = (res.time >= 0.4) & (res.time <= 1.6)
    assert math.sqrt(np.mean(force[window] ** 2)) / weight < 0.05
    assert math.sqrt(np.mean(moment**2)) < 25.0
    ankle = res.moment("right_ankle_flexion") / MASS
    assert 1.2 < np.abs(ankle).max() < 2.2  # [N m/kg] push-off's plantarflexion


def test_subject01_with_ball_ranges_holds_the_trunk_at_its_bound(subject01):
    """The walk fitted with the ball joints' ranges: the trunk's markers want the thoracic
    joint flexed up to 86 deg; it is held at its 45 in every frame and said, every ball joint
    ends within 1e-4 rad of its range (measured 1.4e-5), every frame converged, the root
    residual under 10 % BW (7.1 %; 5.0 without the ranges). Before, every step of the 20th
    frame was refused (each had to bring the trunk back in and raised the cost), Levenberg's
    lambda grew to 1e29 and ProxQP never returned: a watchdog ends the test if the fit takes
    over 5 minutes (it takes 1-2 s)."""
    import faulthandler

    from humanoid.constraints.limits import JointRanges
    from humanoid.motion.commands import read_loads_file
    from humanoid.motion.ik import inverse_kinematics
    from humanoid.motion.inverse_dynamics import inverse_dynamics

    r, _, walk, _ = subject01
    faulthandler.dump_traceback_later(300, exit=True)
    try:
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            fit = inverse_kinematics(r.body, walk, r.marker_set, ball_ranges=True)
    finally:
        faulthandler.cancel_dump_traceback_later()
    held = next(x for x in fit.at_limit if x.coordinate == "thoracic_flexion")
    assert held.limit == "upper" and held.bound == pytest.approx(45.0)
    assert held.frames == len(fit.time) and held.excess > 30.0, held
    assert any("thoracic_flexion held at its upper limit" in str(w.message) for w in said)
    balls = JointRanges(r.body)
    assert max(float(balls.excess(q).max()) for q in fit.q) < 1e-4
    assert fit.converged.all(), np.flatnonzero(~fit.converged)
    res = inverse_dynamics(r.body, fit.time, fit.q, read_loads_file(GRF))
    force = np.linalg.norm(res.residual_force, axis=1)
    assert math.sqrt(np.mean(force**2)) / (r.body.mass * 9.81) < 0.10


def test_subject01_residuals_reduced(subject01):
    """The issue's requirement on a recorded walk: with loads estimated on the fitted floor
    (a treadmill's: its belt found at 1.1-1.2 m/s, the floor tilted about 1-2 deg in the
    lab's axes) the root residual before reduction is under 10 % of body weight RMS (measured
    1.7 %) and after it under 5 % (0.1 %); under the recorded plates 5.0 % before, under
    1.5 % after (0.6 %), the mass within 2 % and the trunk's mass centre moved at most 5 cm."""
    from humanoid.motion.commands import read_loads_file
    from humanoid.motion.floor import fit_floor
    from humanoid.motion.inverse_dynamics import derivatives, estimate_loads
    from humanoid.motion.reduce import reduce_residuals

    r, fit, _, _ = subject01
    h = r.body
    weight = h.mass * 9.81
    floor = fit_floor(h, fit.time, fit.q)
    assert 1.1 < floor.speed < 1.2 and abs(floor.tilt_x_deg) < 1.0, floor
    estimated = estimate_loads(h, *derivatives(h.model, fit.time, fit.q), floor=floor)
    red = reduce_residuals(h, fit.time, fit.q, estimated)
    assert red.force_rms(after=False) / weight < 0.10
    assert red.force_rms() / weight < 0.05
    assert red.mass == h.mass
    plates = reduce_residuals(h, fit.time, fit.q, read_loads_file(GRF))
    assert plates.force_rms(after=False) / weight == pytest.approx(0.050, abs=0.01)
    assert plates.force_rms() / weight < 0.015
    assert plates.moment_rms() < 0.3 * plates.moment_rms(after=False)
    assert plates.mass == pytest.approx(h.mass, rel=0.02)
    assert np.linalg.norm(plates.com_shift) <= 0.05 + 1e-12


def test_subject01_tracked_to_the_end(subject01):
    """The issue's requirement: the recorded walk, without its plates, through IK, residual
    reduction (loads estimated on the fitted floor) and tracking to its end: a treadmill walk,
    followed in the belt's frame. The fitted spine is past its ranges (its trunk's markers
    want 80 deg of thoracic flexion): clamped into them first. Measured (the converged IK, the
    feet landing on the capture point's error, the 2 ms step, the reduction's feet held on their
    floor): completed, the joints 1.6 deg RMS from the reference, the legs 2.7 deg from the IK
    (the whole body 8.1, the clamped spine's 35 deg in it), every joint 1.7 deg from the IK
    clamped into the ranges; the bounds here 5 deg."""
    from humanoid.model import lock_foot_hinges, restrict_configurations
    from humanoid.motion.floor import fit_floor
    from humanoid.motion.inverse_dynamics import derivatives, estimate_loads, joint_labels
    from humanoid.motion.reduce import reduce_residuals
    from humanoid.motion.tracking import inside_ranges, track

    r, fit, _, _ = subject01
    h = r.body
    q, clamped = inside_ranges(h, fit.q)
    assert "thoracic_flexion" in clamped
    floor = fit_floor(h, fit.time, q)
    loads = estimate_loads(h, *derivatives(h.model, fit.time, q), floor=floor)
    red = reduce_residuals(h, fit.time, q, loads)
    res = track(h, red.time, red.q, floor=floor)
    assert res.completed, res.trajectory.metadata.get("message")
    err = res.joint_error[:, 6:]
    assert np.degrees(np.sqrt(np.mean(err**2))) < 5.0
    locked = lock_foot_hinges(h)
    ik = restrict_configurations(fit.q, h, locked)
    steps = np.clip(np.round(res.trajectory.t * 60.0).astype(int), 0, len(ik) - 1)
    off = np.degrees([pin.difference(locked.model, ik[i], x)[6:]
                      for i, x in zip(steps, res.trajectory.q, strict=True)])  # fmt: skip
    labels = joint_labels(locked.model)[6:]
    legs = [k for k, n in enumerate(labels) if any(w in n for w in ("hip", "knee", "ankle"))]
    assert np.sqrt(np.mean(off[:, legs] ** 2)) < 5.0
    # against the IK clamped into the ranges (the IK the body can take), every joint
    inside = restrict_configurations(q, h, locked)
    off = np.degrees([pin.difference(locked.model, inside[i], x)[6:]
                      for i, x in zip(steps, res.trajectory.q, strict=True)])  # fmt: skip
    print(f"tracked vs IK in ranges: {np.sqrt(np.mean(off**2)):.2f} deg RMS")
    assert np.sqrt(np.mean(off**2)) < 5.0


def test_subject01_command_line(tmp_path, capsys):
    """``humanoid scale``, ``ik``, ``id``, ``report`` and ``view --html`` on the shipped
    files, as the README shows them."""
    from humanoid.cli import main

    urdf, markers = tmp_path / "subject01.urdf", tmp_path / "subject01_markers.toml"
    ik, id_, report = tmp_path / "walk1_ik.mot", tmp_path / "walk1_id.sto", tmp_path / "r.png"
    assert main(["scale", str(STATIC), "--mass", str(MASS), "-o", str(urdf)]) == 0
    out = capsys.readouterr().out
    placed = next(x for x in out.splitlines() if x.startswith("placed"))
    assert float(placed.split()[1]) < 10.0  # [mm] RMS
    assert urdf.is_file() and markers.is_file()
    assert main(["ik", str(WALK), "--model", str(urdf), "--marker-set", str(markers),
                 "--map", "gait2354", "-o", str(ik), "--quiet"]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "41 of 41 in the set, 151 frames at 60.0 Hz" in out
    assert main(["id", str(ik), "--model", str(urdf), "--loads", str(GRF), "-o", str(id_)]) == 0
    out = capsys.readouterr().out
    assert "loads        right (ground_), left (1_ground_)" in out
    # the README's comment is what it prints: the right ankle's moment, its minimum and maximum
    said = (ROOT / "README.md").read_text().split("ankle_angle_moment N m/kg min/max: ")[1]
    ankle = next(x for x in out.splitlines() if x.startswith("ankle_angle_moment"))
    assert said.split(";")[0] in ankle, (said.split(";")[0], ankle)
    line = next(x for x in out.splitlines() if x.startswith("root residual force"))
    assert float(line.split("(")[1].split("%")[0]) < 6.0
    rra = tmp_path / "walk1_rra.mot"
    assert main(["id", str(ik), "--model", str(urdf), "--loads", str(GRF), "--reduce",
                 "--reduced", str(rra), "-o", str(tmp_path / "rra.sto")]) == 0  # fmt: skip
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("root residual force"))
    assert float(line.split("(")[1].split("%")[0]) < 1.5
    assert "reduced      force RMS" in out and "thoracic mass centre moved" in out
    assert rra.is_file()
    args = ["report", str(ik), "--moments", str(id_), "--loads", str(GRF), "--model", str(urdf),
            "--mass", str(MASS), "--speed", "1.1", "-o", str(report)]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "cycles 0.618-1.853 s" in out and report.is_file()
    page = tmp_path / "walk1.html"
    assert main(["view", str(ik), "--model", str(urdf), "--markers", str(WALK),
                 "--marker-set", str(markers), "--html", str(page)]) == 0  # fmt: skip
    assert page.stat().st_size > 100_000
