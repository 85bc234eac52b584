"""The command line, called as main([...]) and once as a real process."""

from __future__ import annotations

import contextlib
import csv
import math
import re
import subprocess
import sys

import pytest
from conftest import BODIES, SCENES, viewer_servers

import humanoid as hm
from humanoid.cli import main


def test_build_writes_the_same_body_as_the_api(tmp_path, capsys):
    out = tmp_path / "sub" / "me.urdf"
    code = main(["build", "--height", "1.8", "--mass", "80", "--sex", "female", "-o", str(out)])
    assert code == 0
    assert out.read_text() == hm.build_urdf(hm.BodyParameters(1.8, 80.0, "female"))
    assert "wrote" in capsys.readouterr().out


def test_build_with_a_measured_segment(tmp_path):
    out = tmp_path / "me.urdf"
    argv = ["build", "--height", "1.8", "--mass", "80", "--sex", "male", "--segment", "thigh=0.45"]
    assert main([*argv, "-o", str(out)]) == 0
    expected = hm.BodyParameters(1.8, 80.0, "male", {"thigh": 0.45})
    assert out.read_text() == hm.build_urdf(expected)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--height", "3", "--mass", "70", "--sex", "male"], r"height must be in \[0.5, 2.5\] m"),
        (["--height", "1.7", "--mass", "5", "--sex", "male"], r"mass must be in \[10.0, 300.0\]"),
        (["--height", "1.7", "--mass", "nan", "--sex", "male"], "mass must be in"),
        (
            ["--height", "1.7", "--mass", "70", "--sex", "male", "--segment", "tail=0.3"],
            "unknown segment length 'tail'",
        ),
    ],
)
def test_build_errors_go_to_stderr_without_traceback(tmp_path, capsys, argv, message):
    code = main(["build", *argv, "-o", str(tmp_path / "x.urdf")])
    err = capsys.readouterr().err
    assert code == 2
    assert "Traceback" not in err
    assert err.startswith("humanoid build: error:")
    assert re.search(message, err), err
    assert not (tmp_path / "x.urdf").exists()


def test_info_summarises_our_body(capsys):
    assert main(["info", str(BODIES / "adult_male.urdf")]) == 0
    out = capsys.readouterr().out
    assert "nq = 49, nv = 41" in out
    assert "mass         75.0000 kg" in out
    assert "left_sole, right_sole" in out
    assert "left_hip" in out and "JointModelSpherical" in out
    assert "left_thigh" in out and "14.16%" in out  # de Leva male thigh 0.1416
    assert "postures     none (no SRDF)" in out


def test_info_lists_a_robots_srdf_postures(capsys):
    assert main(["info", "talos"]) == 0
    assert "postures     half_sitting (reference)" in capsys.readouterr().out


def test_info_prints_the_range_of_every_joint(capsys):
    """Hinges with their limits; a ball joint with the ranges of its triplet's three angles
    (what the joint-range constraints hold); the same numbers in Euler mode."""
    import re

    assert main(["info", str(BODIES / "adult_male.urdf")]) == 0
    quaternion = capsys.readouterr().out
    assert main(["info", str(BODIES / "adult_male.urdf"), "--ball-joints", "euler"]) == 0
    euler = capsys.readouterr().out
    table = quaternion.split("range [deg]")[1].split("segment (link)")[0].strip().splitlines()
    ranges = {}
    for line in table:
        match = re.match(r"\s*(\S+).*?(-?\d+\.\d) \.\.\s+(-?\d+\.\d)$", line)
        if match:
            ranges[match[1]] = (float(match[2]), float(match[3]))
        else:
            assert line.endswith(("free", "in order:")), line
    assert ranges["left_hip_flexion"] == (-30.0, 125.0)
    assert ranges["left_knee"] == (0.0, 140.0)
    assert len([x for x in table if "in order:" in x]) == 7  # hips, spine x2, shoulders, neck
    for name, (lo, hi) in ranges.items():
        assert re.search(rf"^{name}\s.*{lo:.1f} \.\.\s+{hi:.1f}$", euler, re.M), name


def test_info_euler_mode_and_erd_name(capsys):
    assert main(["info", "human", "--ball-joints", "euler"]) == 0
    out = capsys.readouterr().out
    assert "nq = 43, nv = 42" in out
    assert "left_hip_X" in out


def test_info_missing_file(capsys):
    assert main(["info", "no/such/model.urdf"]) == 2
    err = capsys.readouterr().err
    assert "URDF file not found: no/such/model.urdf" in err and "Traceback" not in err


def test_python_dash_m_entry_point():
    proc = subprocess.run(
        [sys.executable, "-m", "humanoid", "info", "/nonexistent.urdf"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2
    assert "URDF file not found" in proc.stderr and "Traceback" not in proc.stderr


def test_import_is_light():
    """`import humanoid` imports no viewer, server or browser module."""
    code = (
        "import sys, humanoid; "
        "bad = [m for m in ('meshcat', 'zmq', 'tornado', 'matplotlib', 'playwright') "
        "if m in sys.modules]; print(bad)"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip() == "[]"


def test_simulate_command_writes_the_run_and_a_summary(tmp_path, capsys):
    out = tmp_path / "run.npz"
    scene = str(SCENES / "standing.toml")
    assert main(["simulate", scene, "-o", str(out), "--duration", "0.05", "--quiet"]) == 0
    text = capsys.readouterr().out
    for word in ("simulated", "wall time", "real-time factor", "residual", "energy"):
        assert word in text
    from humanoid.simulation import Trajectory

    traj = Trajectory.load(out)
    assert traj.t[-1] == pytest.approx(0.05) and traj.status == "completed"


def test_simulate_command_saves_a_diverged_run_and_fails(tmp_path, capsys):
    scene = tmp_path / "stiff.toml"
    scene.write_text(
        'dt = 0.01\nduration = 1.0\nintegrator = "euler"\n'
        '[controller]\nkind = "posture"\nkp = 1e6\nkd = 1e4\n'
        '[[effects.contacts]]\nfoot = "left"\n[[effects.contacts]]\nfoot = "right"\n'
        f'[body]\nurdf = "{BODIES / "adult_male.urdf"}"\n'
    )
    out = tmp_path / "run.npz"
    assert main(["simulate", str(scene), "-o", str(out), "--quiet"]) == 3
    captured = capsys.readouterr()
    assert "diverged" in captured.err and "Traceback" not in captured.err
    assert out.is_file()


def test_simulate_command_rejects_a_bad_scene(tmp_path, capsys):
    scene = tmp_path / "bad.toml"
    scene.write_text("dt = -1\n")
    assert main(["simulate", str(scene), "-o", str(tmp_path / "x.npz")]) == 2
    assert "dt: must be a finite number > 0" in capsys.readouterr().err


def test_bench_step_quick(tmp_path, capsys):
    assert main(["bench", "step", "--quick", "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "standing" in out and "tumble" in out
    rows = (tmp_path / "step.csv").read_text().splitlines()
    assert rows[0].startswith("scene,contacts,pinocchio")
    assert len(rows) == 4  # push, standing, tumble
    lines = (tmp_path / "step_ground.csv").read_text().splitlines()
    ground = {r["scene"]: r for r in csv.DictReader(lines)}
    assert set(ground) == {"balance", "collapse", "drop", "slide"}
    assert float(ground["drop"]["ours"]) > 0 and float(ground["drop"]["mujoco"]) > 0
    assert ground["balance"]["mujoco"] == "nan"  # its controller is ours: no MuJoCo column


def test_bench_walk_quick_splits_the_wall_time(tmp_path, capsys):
    """Both control periods of the welded walk and of the person's walk are timed, every
    check passes (every walk completes), the parts add up to the wall time (other >= 0) and
    the bare plant is timed."""
    from humanoid.bench.walk import WALK_COLUMNS

    assert main(["bench", "walk", "--quick", "-o", str(tmp_path)]) == 0
    rows = list(csv.DictReader(open(tmp_path / "walk.csv")))
    assert list(rows[0]) == WALK_COLUMNS and [r["control"] for r in rows] == ["8 ms", "1 ms"]
    parts = ("qp_assembly", "joint_ranges", "qp_solve", "held", "plant", "checks", "records")
    for r in rows:
        assert r["checks_passed"] == "True"
        wall, bare = float(r["wall"]), float(r["bare_plant"])
        assert 0 < bare < wall and float(r["ratio"]) == pytest.approx(wall / bare)
        assert all(float(r[k]) >= 0 for k in parts)
        assert float(r["other"]) >= 0 and float(r["plant"]) > 0 and float(r["qp_solve"]) > 0
    assert float(rows[0]["held"]) > 0 and float(rows[1]["held"]) == 0  # held ticks at 8 ms only
    assert "| 8 ms |" in (tmp_path / "walk.md").read_text()
    # the person's walk: at its QP period (fewer solves than steps, torques held between) and at
    # every step; its parts add up to the wall time
    from humanoid.bench.walk import PERSON_COLUMNS

    rows = list(csv.DictReader(open(tmp_path / "person.csv")))
    assert list(rows[0]) == PERSON_COLUMNS and [r["control"] for r in rows] == ["4 ms", "1 ms"]
    for r in rows:
        assert r["completed"] == "True"
        assert all(float(r[k]) > 0 for k in ("wall", "qp", "plant", "solve", "record", "other"))
        assert float(r["solve"]) < float(r["plant"])
    assert float(rows[0]["solves"]) < 500 and float(rows[1]["solves"]) == pytest.approx(1000)
    assert float(rows[0]["held"]) > 0 and float(rows[1]["held"]) == 0
    assert "| 4 ms |" in (tmp_path / "person.md").read_text()


def test_bench_track_times_the_default_step_and_1_ms(tmp_path, capsys):
    """`bench track` (the male walk alone, quick): a row per step, the default first; each run
    completed, its real-time factor its simulated over its wall seconds, its parts within the
    wall time; the table is the CSV's."""
    from humanoid.bench.track import TRACK_COLUMNS, run_track_benchmark
    from humanoid.motion.tracking import DT

    assert run_track_benchmark(quick=True, out=tmp_path, walks=("male walk",)) == 0
    rows = list(csv.DictReader(open(tmp_path / "track.csv")))
    assert list(rows[0]) == TRACK_COLUMNS
    assert [r["dt"] for r in rows] == [f"{DT * 1e3:g} ms", "1 ms"]
    table = (tmp_path / "track.md").read_text()
    for r in rows:
        assert r["completed"] == "True" and float(r["joint_rms_deg"]) < 1.0
        wall, simulated = float(r["wall"]), float(r["simulated"])
        assert float(r["real_time_factor"]) == pytest.approx(simulated / wall)
        assert float(r["controller"]) > 0 and float(r["plant"]) > 0 and float(r["other"]) >= 0
        assert f"| male walk | {r['dt']} | {simulated:.2f} | {wall:.2f} |" in table


def test_bench_scaling_quick_fits_the_growth(tmp_path, capsys):
    from humanoid.bench.scaling import EXTRA, SCALING_COLUMNS

    assert main(["bench", "scaling", "--quick", "-o", str(tmp_path)]) == 0
    rows = list(csv.DictReader(open(tmp_path / "scaling.csv")))
    assert list(rows[0]) == SCALING_COLUMNS
    nv = {r["body"]: int(r["nv"]) for r in rows}
    assert nv["male"] == 39 and all(nv[f"male + {k} trunk"] == 39 + 3 * k for k in EXTRA)
    contacts = list(csv.DictReader(open(tmp_path / "scaling_contacts.csv")))
    assert [int(c["rows"]) for c in contacts] == [0, 6, 12, 18, 24, 30]
    assert (tmp_path / "scaling.png").stat().st_size > 10_000
    assert "per degree of freedom" in capsys.readouterr().out


def test_view_writes_html_for_a_model_and_a_run(tmp_path, capsys):
    out = tmp_path / "model.html"
    assert main(["view", str(BODIES / "adult_female.urdf"), "--html", str(out)]) == 0
    assert out.is_file() and "humanoidCommands" in out.read_text()
    run = tmp_path / "run.npz"
    scene = str(SCENES / "standing.toml")
    assert main(["simulate", scene, "-o", str(run), "--duration", "0.1", "--quiet"]) == 0
    page = tmp_path / "run.html"
    assert main(["view", str(run), "--html", str(page), "--speed", "0.5", "--no-com"]) == 0
    html = page.read_text()
    assert "var t0 = 0.0, speed = 0.5, duration = 0.2" in html  # 0.1 s played at half speed
    assert "centre of mass" not in html.split('id="legend"')[1].split("</div>\n")[0]


def test_view_live_prints_a_loopback_url_and_stops_on_ctrl_c():
    import signal

    def terminal_ctrl_c():
        # Ctrl-C as a terminal has it: a test worker may run with SIGINT ignored or blocked
        # (both survive exec, and Python then installs no KeyboardInterrupt), which hung this
        # test in the full suite
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})

    proc = subprocess.Popen(
        [sys.executable, "-m", "humanoid", "view", str(BODIES / "adult_male.urdf")],
        stdout=subprocess.PIPE,
        text=True,
        preexec_fn=terminal_ctrl_c,
    )
    try:
        line = proc.stdout.readline()
        assert line.startswith("viewer at http://127.0.0.1:"), line
        # the package's page (legend, follow camera) is served beside meshcat's own
        from urllib.request import urlopen

        url = line.split()[2]
        assert url.endswith("/humanoid/"), line
        with urlopen(url, timeout=10) as response:
            html = response.read().decode()
        assert 'id="legend"' in html and "viewer.connect()" in html
        assert proc.stdout.readline().startswith("meshcat's own page: http://127.0.0.1:")
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=15) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not viewer_servers()


def _accuracy_run(out):
    """One quick `bench accuracy` run: (exit code, folder, printed text). Shared by the two
    checks below in one test: as a fixture, pytest-xdist's workers each ran it (3 minutes of
    CPU each)."""
    import contextlib
    import io

    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        code = main(["bench", "accuracy", "--quick", "-o", str(out)])
    return code, out, text.getvalue()


def test_bench_accuracy_quick_measures_the_orders_and_runs_the_peers(tmp_path):
    run = _accuracy_run(tmp_path)
    _assert_the_orders(run)
    _assert_the_peers(run)


def _assert_the_orders(accuracy_run):
    """The work-precision sweep (quick): files written, and the errors behave as the schemes
    say (RK4 shrinks ~16x per halving of dt, the Euler schemes ~2x)."""
    import csv

    code, tmp_path, text = accuracy_run
    assert code == 0
    rows = list(csv.DictReader(open(tmp_path / "accuracy.csv")))
    for scene in ("tumble", "swing", "stance"):
        assert (tmp_path / f"accuracy_{scene}.png").is_file()

    def error(scene, method, dt):
        row = next(r for r in rows if (r["scene"], r["method"], r["setting"]) ==
                   (scene, method, f"dt={dt:g}"))  # fmt: skip
        return float(row["error"])

    for scene in ("tumble", "swing"):
        assert error(scene, "rk4", 4e-3) / error(scene, "rk4", 2e-3) > 10
        ratio = error(scene, "semi_implicit_euler", 4e-3) / error(
            scene, "semi_implicit_euler", 2e-3
        )
        assert 1.6 < ratio < 2.5
    # both quaternion formulations converge to the same reference
    assert error("tumble", "rk4, coordinates", 1e-3) < 1e-8
    # the walking segment (controller at 2 ms): RK4 is far closer to the reference
    assert error("walk", "rk4", 2e-3) < 1e-3 * error("walk", "semi_implicit_euler", 2e-3)
    # the references converged: rtol 1e-12 against 1e-10 agree far below every swept error
    convergence = dict(csv.reader(open(tmp_path / "convergence.csv")))
    for scene in ("tumble", "swing", "stance", "walk"):
        assert float(convergence[scene]) < 1e-8, scene
    # the adaptive walk (2 ms ticks, the controller's): every tolerance lands at the controller's
    # noise floor, below RK4 at 2 ms
    walk_dp5 = [float(r["error"]) for r in rows if (r["scene"], r["method"]) ==
                ("walk", "adaptive (DP5)")]  # fmt: skip
    assert len(walk_dp5) == 3 and max(walk_dp5) < error("walk", "rk4", 2e-3)
    assert "reference convergence" in text
    # the falls: MuJoCo's stiffest contacts go less deep than its defaults at every step
    depth = {(r["method"], r["setting"]): float(r["constraint_drift"]) for r in rows
             if r["scene"] == "drop" and r["method"].startswith("MuJoCo")}  # fmt: skip
    if depth:
        for dt in ("0.002", "0.001", "0.0005"):
            soft = depth[("MuJoCo soft contacts (Euler)", f"dt={dt}")]
            assert depth[("MuJoCo stiff contacts (Euler)", f"dt={dt}")] < 0.3 * soft, dt


def test_the_falls_alone_replace_their_rows_and_keep_the_others(tmp_path):
    """``run_fall_benchmark`` (``scripts/bench_accuracy.py --falls``): the falls' rows of an
    existing accuracy.csv are replaced, every other scene's row is kept as it was."""
    import csv

    from humanoid.bench.accuracy import Row, run_fall_benchmark

    fields = list(Row.__dataclass_fields__)
    old = [["tumble", "rk4", "dt=0.001", *["1.5"] * (len(fields) - 3)],
           ["drop", "stale", "dt=0.001", *["2.5"] * (len(fields) - 3)]]  # fmt: skip
    with open(tmp_path / "accuracy.csv", "w", newline="") as fh:
        csv.writer(fh).writerows([fields, *old])
    assert run_fall_benchmark(quick=True, out=tmp_path) == 0
    rows = list(csv.reader(open(tmp_path / "accuracy.csv")))
    assert rows[0] == fields and rows[1] == old[0]
    assert all(r[1] != "stale" for r in rows)
    assert {r[0] for r in rows[2:]} == {"collapse", "drop", "slide"}
    assert all((tmp_path / f"accuracy_{name}.png").is_file() for name in ("drop", "slide"))


def _assert_the_peers(accuracy_run):
    """Written by `bench accuracy` when MuJoCo is installed (it is, in the test extras): the
    free scenes, the controlled and the passive welded scenes and the walk, in both engines."""
    import csv

    pytest.importorskip("mujoco")
    code, tmp_path, text = accuracy_run
    rows = list(csv.DictReader(open(tmp_path / "peers.csv")))

    def errors(engine, method, scene, key="error"):
        return [float(r[key]) for r in rows
                if (r["engine"], r["method"], r["scene"]) == (engine, method, scene)]  # fmt: skip

    assert len(errors("mujoco", "RK4", "swing")) == 3
    mujoco_rk4, ours_rk4 = errors("mujoco", "RK4", "tumble"), errors("humanoid", "rk4", "tumble")
    assert len(mujoco_rk4) == len(ours_rk4) == 3
    # same body, same motion: both RK4s conserve energy ever better as the step shrinks
    assert mujoco_rk4[0] > mujoco_rk4[-1] and ours_rk4[0] > ours_rk4[-1]
    # every run either measured a finite error or reported failure (inf); never NaN
    assert all(not math.isnan(float(r["error"])) for r in rows)
    for scene in ("stance", "collapse"):
        # MuJoCo's stiffest welds hold the pushed stance and the collapse, but drift by design
        # (soft constraints); our projected welds stay at round-off at every step
        soft = errors("mujoco", "RK4, stiff weld", scene)
        assert len(soft) == 3 and all(1e-7 < e < 1e-3 for e in soft), (scene, soft)
        assert max(errors("humanoid", "semi-implicit, projection", scene)) < 1e-10
    # the walk, driven by the same controller in both engines: MuJoCo's stiff welds complete
    # it, and their soft contact keeps it far from the rigid-contact reference, which our RK4
    # matches closely at the same 2 ms step
    soft = errors("mujoco", "RK4, stiff weld", "walk")
    assert len(soft) == 2 and all(math.isfinite(e) for e in soft)
    assert max(errors("humanoid", "rk4", "walk")) < 1e-3 * min(soft)
    assert all(d < 1e-2 for d in errors("mujoco", "RK4, stiff weld", "walk", "drift"))
    assert "time to reach the target accuracy" in text
    assert "walk (target" in text
    assert (tmp_path / "peers.png").stat().st_size > 10_000


def test_massless_models_are_refused_or_merged_on_request(tmp_path, capsys):
    assert main(["walk", "--model", "romeo", "--steps", "2", "-o", str(tmp_path / "w.npz")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("humanoid walk: error:") and "--massless merge" in err
    assert main(["info", "romeo", "--massless", "merge"]) == 0
    assert "nv = 37" in capsys.readouterr().out


def test_simulate_calls_energy_change_drift_only_where_energy_is_conserved(tmp_path, capsys):
    assert main(["simulate", "tumble", "--duration", "0.05", "-o", str(tmp_path / "t.npz")]) == 0
    assert "energy       drift " in capsys.readouterr().out
    assert main(["simulate", "push", "--duration", "0.05", "-o", str(tmp_path / "p.npz")]) == 0
    out = capsys.readouterr().out
    assert "energy       change (pushes, controller, joint-range damping):" in out
    assert "drift" not in out.split("energy")[1].splitlines()[0]


def test_the_version_and_defaults_in_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"humanoid {hm.__version__}"
    with pytest.raises(SystemExit):
        main(["walk", "--help"])
    assert "(default: adult_male)" in capsys.readouterr().out


def test_feet_option_names_the_soles_and_bad_names_are_one_line(capsys):
    """--feet picks the sole frames (a user's robot whose frames say neither sole nor foot);
    a frame that is not there is one line on stderr that lists the frames."""
    assert main(["info", "adult_male", "--feet", "left_foot", "right_foot"]) == 0
    assert "left_foot" in capsys.readouterr().out
    assert main(["info", "adult_male", "--feet", "nope", "right_sole"]) == 2
    err = capsys.readouterr().err
    assert "no frame 'nope'" in err and "left_sole" in err and "Traceback" not in err


@pytest.mark.parametrize(("argv", "message"), [
    (["--dt", "0.5"], "--dt must be in (0, 0.01], got 0.5"),
    (["--drop", "0"], "--drop must be in (0, 0.2], got 0.0"),
    (["--integrator", "leapfrog"], "invalid choice: 'leapfrog'"),
    (["--gait", "welded", "--push", "forward:0.1"],
     "--push: only with --gait person or human"),
    (["--gait", "welded", "--report", "r.png"], "--report: only with --gait person or human"),
    (["--push", "left:0.1"], "--push acts in the third stride"),
    (["--figure", "w.png"], "--figure: only with --gait welded"),
    (["--gait", "human", "--drop", "0.02"], "--drop: only with --gait welded"),
    (["--gait", "human", "--integrator", "rk4"], "--integrator: only with --gait welded"),
    (["--gait", "human", "--push", "up:0.1"], "--push 'up:0.1': give DIRECTION:FRACTION"),
    (["--gait", "human", "--push", "left:x"], "--push 'left:x': give DIRECTION:FRACTION"),
    (["--gait", "human", "--push", "left:0.1"], "--push acts in the third stride"),
    (["--from-standing"], "--from-standing: give --steps 7 or more"),
    (["--gait", "welded", "--from-standing"],
     "--from-standing: only with --gait person or human"),
    (["--gait", "human", "--from-standing"], "--from-standing: give --steps 3 or more"),
    (["--gait", "welded", "--radius", "2"], "--radius: only with --gait person or human"),
    (["--radius", "0.5"], "a circle's radius must be finite and at least 1.0 m"),
    (["--radius", "2", "--push", "left:0.1"], "--push: a push is along the room's axes"),
    (["--from-standing", "--largest-push", "left"], "--largest-push: a straight walk's"),
    (["--gait", "human", "--control-dt", "0.004"], "--control-dt: only with --gait welded or"),
    (["--control-dt", "0.0025"], "control_dt must be a whole number of steps of 0.001 s"),
])  # fmt: skip
def test_walk_options_are_checked_in_their_own_words(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) if "choice" in message else contextlib.nullcontext():
        code = main(["walk", "--steps", "2", "-o", str(tmp_path / "w.npz"), *argv])
        assert code == 2
    assert message in capsys.readouterr().err


def test_variants_lists_every_registry(capsys):
    from humanoid.variants import REGISTRIES

    assert main(["variants"]) == 0
    out = capsys.readouterr().out
    for registry in REGISTRIES:
        assert registry.what in out and all(name in out for name in registry)


def test_the_parsers_keypoint_layouts_are_the_toolkits():
    """The parser names the layouts without importing the motion package: the same names, in
    the same order, as humanoid.motion.markers.KEYPOINT_LAYOUTS; every command that reads
    keypoints offers them all."""
    from humanoid import cli
    from humanoid.motion.markers import KEYPOINT_LAYOUTS

    assert cli.KEYPOINT_LAYOUTS == tuple(KEYPOINT_LAYOUTS)
    parser = cli.build_parser()
    for command in ("view", "ik", "track"):
        args = parser.parse_args([command, "x", "--layout", "halpe26"])
        assert args.layout == "halpe26"
