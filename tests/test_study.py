"""Studies (`humanoid sweep`): the Parquet rows from a 2-worker Dask cluster equal a serial run
of the same study exactly; a study killed half way finishes only the remaining runs when run
again; a worker killed mid-run is replaced and its run retried, every row present once; a run
that raises is a failed row with its message; a bad study file is a StudyError naming the key.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from humanoid.errors import StudyError
from humanoid.study import load_study, parse_study, read_table, run_study
from humanoid.study.figures import (
    best_per_group,
    mean_per_group,
    plot_study,
    threshold_per_group,
)

# a small study: the welded standing scene for 0.6 s, 2 bodies x 3 pushes (about 0.5 s a run),
# and a run whose push names no frame of the body (it raises: a failed row)
TINY = """
[study]
name = "tiny"
run = "scene"
scene = "standing"

[set]
"scene.duration" = 0.6
"push.start" = 0.1
"push.duration" = 0.2
"body.sex" = "female"
"body.bmi" = 22.0

[grid]
"body.height" = [1.55, 1.85]
"push.fraction" = [0.05, 0.1, 0.2]
"push.frame" = ["thorax"]
"""
BROKEN_RUN = TINY.replace('"push.frame" = ["thorax"]', '"push.frame" = ["thorax", "tail"]')
VOLATILE = ("wall_time", "worker")  # the columns that differ between two runs of one study


def _study(tmp_path: Path, text: str = TINY, name: str = "tiny.toml"):
    path = tmp_path / name
    path.write_text(text)
    return load_study(path)


def _same(a: list[dict], b: list[dict]) -> None:
    """The tables hold the same runs with bitwise the same values (NaN equal to NaN)."""
    assert [r["run"] for r in a] == [r["run"] for r in b]
    for x, y in zip(a, b, strict=True):
        assert set(x) == set(y)
        for k in x:
            if k in VOLATILE:
                continue
            same = x[k] == y[k] or (
                isinstance(x[k], float) and math.isnan(x[k]) and math.isnan(y[k])
            )
            assert same, (x["run"], k, x[k], y[k])


@contextlib.contextmanager
def _local_client(config=None):
    """A 2-worker LocalCluster (worker processes, as `humanoid sweep` starts) and its client,
    under a Dask ``config`` if given."""
    import logging

    import dask
    from distributed import Client, LocalCluster

    with dask.config.set(config or {}), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                         dashboard_address=":0", silence_logs=logging.CRITICAL) as c, \
            Client(c) as client:  # fmt: skip
        yield client


def _study_with_a_worker_killed(client, study, folder):
    """Run ``study`` on ``client`` while SIGKILLing the process of a worker inside a run;
    returns (the StudyRun, the killed pid)."""
    box = {}
    thread = threading.Thread(
        target=lambda: box.update(result=run_study(study, folder, client=client, quiet=True))
    )
    thread.start()
    victim, deadline = None, time.monotonic() + 60
    while victim is None and time.monotonic() < deadline:
        busy = [w for w, tasks in client.processing().items() if tasks]
        if busy:
            time.sleep(0.2)  # inside the run
            victim = client.run(os.getpid, workers=[busy[0]])[busy[0]]
        time.sleep(0.02)
    assert victim is not None
    os.kill(victim, signal.SIGKILL)
    thread.join(timeout=240)
    assert not thread.is_alive()
    return box["result"], victim


@pytest.fixture(scope="module")
def cluster():
    with _local_client() as client:
        yield client


@pytest.fixture(scope="module")
def serial_rows(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("serial")
    study = _study(tmp, BROKEN_RUN)
    result = run_study(study, tmp / "out", serial=True, quiet=True)
    assert result.ran == 12 and result.skipped == 0
    return read_table(result.table)


def test_a_cluster_gives_the_rows_of_a_serial_run(tmp_path, cluster, serial_rows):
    study = _study(tmp_path, BROKEN_RUN)
    result = run_study(study, tmp_path / "out", client=cluster, quiet=True)
    assert result.ran == 12 and result.workers == 2
    rows = read_table(result.table)
    _same(rows, serial_rows)
    workers = {r["worker"] for r in rows}
    assert len(workers) == 2  # both workers ran some
    assert os.getpid() not in {int(w.rsplit(":", 1)[1]) for w in workers}


def test_a_run_that_raises_is_a_failed_row_with_its_message(serial_rows):
    failed = [r for r in serial_rows if r["push.frame"] == "tail"]
    assert len(failed) == 6 and all(r["status"] == "failed" for r in failed)
    assert all("no frame 'tail'" in r["message"] for r in failed)
    assert all(math.isnan(r["pelvis_min"]) for r in failed)
    good = [r for r in serial_rows if r["push.frame"] == "thorax"]
    assert all(r["status"] == "completed" and r["message"] == "" for r in good)
    # the push is the fraction of the run's own body weight, 9.81 m/s^2
    for r in good:
        assert abs(r["push_force"] - r["push.fraction"] * r["mass"] * 9.81) < 1e-9 * r["mass"]
        assert abs(r["mass"] - 22.0 * r["body.height"] ** 2) < 1e-9


def test_the_same_study_again_runs_nothing(tmp_path):
    study = _study(tmp_path)
    first = run_study(study, tmp_path / "out", serial=True, quiet=True)
    again = run_study(study, tmp_path / "out", serial=True, quiet=True)
    assert (first.ran, again.ran, again.skipped) == (6, 0, 6)
    _same(read_table(first.table), read_table(again.table))
    assert [r["wall_time"] for r in read_table(first.table)] == [
        r["wall_time"] for r in read_table(again.table)
    ]


def test_kept_trajectories_are_saved_beside_the_table(tmp_path):
    import humanoid as hm

    text = TINY.replace('name = "tiny"', 'name = "kept"\nkeep = "trajectory"')
    text = text.replace('"scene.duration" = 0.6', '"scene.duration" = 0.1')
    study = _study(tmp_path, text.replace("[0.05, 0.1, 0.2]", "[0.1]"))
    result = run_study(study, tmp_path / "out", serial=True, quiet=True)
    rows = read_table(result.table)
    assert len(rows) == 2
    for r in rows:
        traj = hm.Trajectory.load(tmp_path / "out" / r["trajectory"])
        assert traj.status == "completed" and abs(traj.t[-1] - 0.1) < 1e-9
    assert not list((tmp_path / "out" / "trajectories").glob("*.part*"))


def test_a_killed_study_finishes_the_remaining_runs_only(tmp_path):
    """`humanoid sweep` killed (SIGKILL, the whole process group: the study and its workers)
    once some rows are written; the same command again runs the others, and the table equals
    the serial run's. (24 runs of about 0.4 s: the table, rewritten every 2 s, is seen with
    some rows and not all; with 12 runs, half of them failing at once, a slow cluster start
    once let the study finish before the first rewrite.)"""
    text = TINY.replace("[0.05, 0.1, 0.2]", "[0.02, 0.04, 0.06, 0.08, 0.1, 0.12, 0.14, 0.16, "
                                           "0.18, 0.2, 0.22, 0.24]")  # fmt: skip
    path = tmp_path / "tiny.toml"
    path.write_text(text)
    serial = read_table(run_study(load_study(path), tmp_path / "serial", serial=True,
                                  quiet=True).table)  # fmt: skip
    assert len(serial) == 24
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "humanoid", "sweep", str(path), "-o", str(out),
           "--workers", "2", "--quiet"]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            start_new_session=True)  # fmt: skip
    table = out / "results.parquet"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if table.is_file() and 2 <= len(read_table(table)) < 24:
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    before = {r["run"]: r for r in read_table(table)}
    assert 2 <= len(before) < 24, len(before)
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"{24 - len(before)} ran, {len(before)} were already done" in done.stdout
    after = read_table(table)
    _same(after, serial)
    for r in after:  # the first session's rows are kept as they were
        if r["run"] in before:
            assert r["wall_time"] == before[r["run"]]["wall_time"]
            assert r["worker"] == before[r["run"]]["worker"]


def test_a_worker_killed_mid_run_is_replaced_and_the_run_retried(tmp_path, serial_rows):
    """A worker process is SIGKILLed while it runs a task: the nanny starts a new one, the
    scheduler reruns the task, and the study ends with every row once, equal to serial."""
    study = _study(tmp_path, BROKEN_RUN)
    with _local_client() as client:
        before = set(client.run(os.getpid).values())
        result, victim = _study_with_a_worker_killed(client, study, tmp_path / "out")
        client.wait_for_workers(2, timeout=60)
        after = set(client.run(os.getpid).values())
    assert victim in before and victim not in after  # a new worker took its place
    assert result.ran == 12
    rows = read_table(result.table)
    assert len({r["run"] for r in rows}) == len(rows) == 12
    _same(rows, serial_rows)


def test_a_run_whose_workers_keep_dying_is_an_error_row(tmp_path):
    """With no retries allowed (`distributed.scheduler.allowed-failures` = 0), the run whose
    worker is SIGKILLed becomes a row with status error and says why; the study finishes
    with every other row."""
    study = _study(tmp_path)
    with _local_client({"distributed.scheduler.allowed-failures": 0}) as client:
        result, _ = _study_with_a_worker_killed(client, study, tmp_path / "out")
    rows = read_table(result.table)
    assert len(rows) == 6 and len({r["run"] for r in rows}) == 6
    errors = [r for r in rows if r["status"] == "error"]
    assert len(errors) >= 1 and all("worker died" in r["message"] for r in errors)
    assert sum(r["status"] == "completed" for r in rows) == 6 - len(errors)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (('"body.bmi" = 22.0', '"body.bmx" = 22.0'), "set.body.bmx: unknown parameter"),
        (("[1.55, 1.85]", "[1.55, 3.1]"), "grid.body.height: run 3"),
        (('name = "tiny"', 'name = "a/b"'), "study.name"),
        (('scene = "standing"', 'scene = "nowhere"'), "study.scene"),
        (('"scene.duration" = 0.6', '"scene.integrator" = "leapfrog"'), "scene.integrator"),
        (('"scene.duration" = 0.6', '"walk.speed" = 1.2'), "set.walk.speed: walk.* parameters"),
        (('"push.start" = 0.1', '"push.start" = "soon"'), "set.push.start: a positive number"),
        (('"push.fraction" = [0.05, 0.1, 0.2]', '"push.fraction" = []'), "grid.push.fraction"),
        (('"body.bmi" = 22.0', '"body.mass" = 60.0\n"body.bmi" = 22.0'), "not both"),
        (("[grid]", "[grids]"), "grids: unknown section"),
        (('run = "scene"', 'run = "dance"'), "study.run"),
    ],
)
def test_a_bad_study_file_names_the_key(tmp_path, edit, message):
    path = tmp_path / "bad.toml"
    path.write_text(TINY.replace(*edit))
    with pytest.raises(StudyError, match="bad.toml") as err:
        load_study(path)
    assert message in str(err.value)


def test_bad_samples_and_figures_name_the_key():
    base = {"study": {"name": "s", "run": "walk"}, "set": {"body.bmi": 22.0, "body.sex": "male"}}
    cases = [
        ({"sample": {"n": 3, "body.height": {"gauss": [1.7, 0.1]}}}, "sample.body.height"),
        ({"sample": {"n": 0, "body.height": {"normal": [1.7, 0.1]}}}, "sample.n"),
        ({"sample": {"n": 2, "body.height": {"uniform": [1.9, 1.7]}}}, "uniform"),
        (
            {
                "grid": {"body.height": [1.7]},
                "figure": {"kind": "best", "value": "speed", "of": "joy", "x": "body.height"},
            },
            "figure.of",
        ),  # fmt: skip
    ]
    for extra, message in cases:
        with pytest.raises(StudyError, match=message):
            parse_study({**base, **extra}, source="s.toml")


def test_samples_are_seeded_and_clipped():
    doc = {"study": {"name": "s", "run": "walk", "seed": 7},
           "set": {"body.bmi": 22.0},
           "grid": {"walk.speed_ratio": [0.9, 1.1]},
           "sample": {"n": 50, "body.height": {"normal": [1.7, 0.2], "clip": [1.5, 1.9]},
                      "body.sex": {"choice": ["male", "female"]}}}  # fmt: skip
    a, b = parse_study(doc).runs(), parse_study(doc).runs()
    assert len(a) == 100 and [r.params for r in a] == [r.params for r in b]
    assert [r.id for r in a] == [r.id for r in b] and len({r.id for r in a}) == 100
    heights = [r.params["body.height"] for r in a]
    assert min(heights) == 1.5 and max(heights) == 1.9  # clipped (a 0.2 m spread reaches both)
    assert {r.params["body.sex"] for r in a} == {"male", "female"}
    doc["study"]["seed"] = 8
    assert [r.params for r in parse_study(doc).runs()] != [r.params for r in a]


def test_the_figures_reduce_the_table_as_stated(tmp_path):
    rows = []
    for sex in ("female", "male"):
        for h in (1.6, 1.8):
            for f in (0.1, 0.2, 0.3, 0.4):
                survived = f < (0.25 if h == 1.8 else 0.15) + (0.1 if sex == "male" else 0)
                survived |= (sex, h, f) == ("female", 1.6, 0.3)  # survived again above
                rows.append({"body.sex": sex, "body.height": h, "push.fraction": f,
                             "survived": survived, "status": "completed",
                             "speed": f, "cost": (f - h / 9) ** 2})  # fmt: skip
    fig = {"kind": "threshold", "value": "push.fraction", "where": "survived",
           "x": "body.height", "panels": "body.sex"}  # fmt: skip
    found = threshold_per_group(rows, fig)
    assert found == {("female", None, 1.6): (0.1, [0.3]), ("female", None, 1.8): (0.2, []),
                     ("male", None, 1.6): (0.2, []), ("male", None, 1.8): (0.3, [])}  # fmt: skip
    best = best_per_group(rows, {"kind": "best", "value": "speed", "of": "cost",
                                 "x": "body.height", "series": "body.sex"})  # fmt: skip
    assert best[(None, "female", 1.6)][0] == 0.2 and best[(None, "male", 1.8)][0] == 0.2
    line = {"kind": "line", "value": "speed", "reference": "cost", "x": "body.height",
            "series": "body.sex"}  # fmt: skip
    rows[0]["status"] = "fell"  # left out of the mean
    mean = mean_per_group(rows, line)
    assert mean[(None, "female", 1.6)] == pytest.approx(0.3)  # (0.2 + 0.3 + 0.4) / 3
    assert mean[(None, "male", 1.8)] == pytest.approx(0.25)
    for f in (fig, line, {"kind": "best", "value": "speed", "of": "cost", "x": "body.height"}):
        path = plot_study(rows, f, tmp_path / f"{f['kind']}.png")
        assert path.stat().st_size > 10_000


def test_the_shipped_studies_load_and_their_folders_are_guarded(tmp_path):
    """Both shipped studies load (every run's body and scene checked) with the run counts
    the README gives; a folder holding another study's results is refused."""
    from humanoid.study.commands import resolve

    push, walk = load_study(resolve("push_standing")), load_study(resolve("walk_speed"))
    assert len(push.runs()) == 5 * 5 * 2 * 15 and len(walk.runs()) == 5 * 2 * 3
    assert len(load_study(resolve("push_slice")).runs()) == 24
    repo = Path(__file__).resolve().parents[1] / "models" / "studies"
    for name in ("push_standing", "walk_speed", "push_slice"):
        assert (repo / f"{name}.toml").read_text() == resolve(name).read_text()
    tiny = _study(tmp_path)
    run_study(tiny, tmp_path / "out", serial=True, quiet=True)
    with pytest.raises(StudyError, match="another study"):
        run_study(push, tmp_path / "out", serial=True, quiet=True)


def test_sweep_on_an_existing_scheduler_and_its_report(tmp_path, cluster, serial_rows):
    """`humanoid sweep --scheduler ADDRESS` runs the study on that cluster unchanged; the
    report counts the runs by status; a second invocation runs nothing; --list shows each
    run's state; bad input is one line on stderr with exit code 2."""
    path = tmp_path / "tiny.toml"
    path.write_text(BROKEN_RUN)
    out = tmp_path / "out"
    address = cluster.scheduler.address
    base = [sys.executable, "-m", "humanoid", "sweep", str(path), "-o", str(out), "--quiet"]
    first = subprocess.run([*base, "--scheduler", address], capture_output=True, text=True,
                           timeout=300)  # fmt: skip
    assert first.returncode == 0, first.stderr
    assert "runs         12: 6 completed, 6 failed" in first.stdout
    assert "12 ran, 0 were already done" in first.stdout
    _same(read_table(out), serial_rows)
    report = (out / "result.md").read_text()
    assert report.startswith("`humanoid sweep tiny`: 12 runs (6 completed, 6 failed); a run")
    again = subprocess.run(base + ["--serial"], capture_output=True, text=True, timeout=120)
    assert "0 ran, 12 were already done" in again.stdout
    listed = subprocess.run(base + ["--list"], capture_output=True, text=True, timeout=120)
    lines = listed.stdout.splitlines()
    assert len(lines) == 12 and sum("failed" in line for line in lines) == 6
    bad = subprocess.run([sys.executable, "-m", "humanoid", "sweep", str(tmp_path / "no.toml")],
                         capture_output=True, text=True, timeout=120)  # fmt: skip
    assert bad.returncode == 2 and bad.stderr.startswith("humanoid sweep: error: no study file")
    assert "Traceback" not in bad.stderr
    nowhere = subprocess.run([*base, "--fresh", "--scheduler", "nowhere"], capture_output=True,
                             text=True, timeout=120)  # fmt: skip
    assert nowhere.returncode == 2 and "cannot reach the Dask scheduler at 'nowhere'" in (
        nowhere.stderr
    )
