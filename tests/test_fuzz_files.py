"""Fuzzing every file format and every motion command (issue 38): seeded, small, typed.

Each format starts from a small valid file the toolkit writes (or a shipped one, cut short)
and is mutated with a seeded numpy Generator (``tests/fuzz_tools.py``): numbers replaced by
nan, inf, 1e300, -1, 0 or huge integers, fields deleted, duplicated or given another type,
lines shuffled, units swapped, files truncated or emptied, bytes that are not UTF-8. Every
case must end in a result whose numbers are finite or in a typed
:class:`~humanoid.errors.HumanoidError`, within its time (a numpy RuntimeWarning counts as an
untyped exception). C3D files mutated byte by byte are read in a child process
(``tests/fuzz_c3d_worker.py``): ezc3d crashed the interpreter on a truncated file. The
counts go to ``results/fuzz_files.json`` (``pytest -s`` prints them).

tests/test_fuzz.py fuzzes body parameters, URDFs, scenes as run, states, run files and the
model commands; tests/test_bad_input.py keeps the findings of earlier fuzz runs as cases.
"""

from __future__ import annotations

import argparse
import io
import json
import subprocess
import sys
import time
import tomllib
from collections import Counter
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from conftest import get_model
from fuzz_tools import BAD_NUMBERS, cases, finite, generator, mutate_text, outcome, write

import humanoid as hm
from humanoid.cli import main
from humanoid.motion import cameras as cam
from humanoid.motion.bvh import read_bvh, write_bvh
from humanoid.motion.commands import markers_file
from humanoid.motion.coordinates import configurations, coordinates_table, read_map
from humanoid.motion.loads import read_loads
from humanoid.motion.markers import (
    MarkerTrajectories,
    default_markers,
    marker_positions,
    read_c3d,
    read_markers,
    read_trc,
    write_markers,
    write_trc,
)
from humanoid.motion.storage import read_storage, write_storage
from humanoid.study.spec import load_study

HERE = Path(__file__).resolve().parent
TRIALS = Path(hm.__file__).parent / "data" / "trials"
MARKERS = Path(hm.__file__).parent / "data" / "markers"
COUNTS: dict[str, Counter] = {}
FAILURES: dict[str, list[str]] = {}
SLOWEST: list[tuple[float, str]] = []  # (seconds, case): the budget's spenders


@pytest.fixture(scope="module", autouse=True)
def report():
    yield
    out = HERE.parent / "results" / "fuzz_files.json"
    out.parent.mkdir(exist_ok=True)
    table = {k: dict(v) for k, v in sorted(COUNTS.items())}
    slowest = [f"{t:.3f} s {what}" for t, what in sorted(SLOWEST, reverse=True)[:15]]
    out.write_text(json.dumps({"counts": table, "failures": FAILURES, "slowest": slowest},
                              indent=1))  # fmt: skip
    print("\nfuzz counts:", json.dumps(table))


def run_cases(name: str, n: int, case, seconds: float = 5.0) -> None:
    """``n`` cases of ``case(rng, i)`` -> (what, fn, check), seeded by the format's name;
    fails listing every case that ended otherwise than finite or typed."""
    rng = generator(name)
    counts, bad = COUNTS.setdefault(name, Counter()), []
    for i in range(cases(n)):
        what, fn, check = case(rng, i)
        start = time.perf_counter()
        result = outcome(fn, check, seconds)
        SLOWEST.append((time.perf_counter() - start, f"{name} case {i} ({what})"))
        counts[result.split(":")[0]] += 1
        if result not in ("finite", "typed"):
            bad.append(f"{name} case {i} ({what}): {result}")
    FAILURES[name] = bad
    assert not bad, "\n".join(bad[:20]) + f"\n({len(bad)} of {cases(n)} cases)"


def _markers_ok(m) -> bool:
    return (
        isinstance(m, MarkerTrajectories)
        and finite(m.time)
        and finite(m.positions, nan_ok=True)
        and len(m.time) > 0
    )


@pytest.fixture(scope="module")
def body():
    return get_model("male", "quaternion")


@pytest.fixture(scope="module")
def motion(body):
    """(time, q): 8 frames of the male body rising on its toes a little."""
    t = np.arange(8) / 60.0
    q = np.tile(body.standing_configuration(), (8, 1))
    q[:, 0] += 0.02 * np.arange(8)
    q[:, 7:] += 0.05 * np.sin(np.arange(8))[:, None]
    return t, q


# -- marker and motion text files ------------------------------------------------------------
def test_fuzz_trc(tmp_path):
    base = "\n".join((TRIALS / "subject01_walk1.trc").read_text().splitlines()[:14]) + "\n"
    swaps = [("\tmm\t", "\tm\t"), ("\tmm\t", "\tinches\t"), ("\tmm\t", "\t\t"),
             ("60.00", "0"), ("60.00", "nan"), ("R.ASIS", "L.ASIS"), ("X1", "")]  # fmt: skip

    def case(rng, i):
        text, what = mutate_text(base, rng, swaps)
        path = write(tmp_path / f"{i}.trc", text)
        return what, lambda: read_trc(path), _markers_ok

    run_cases("TRC", 400, case)


def test_fuzz_storage_coordinates(tmp_path, body, motion):
    path = write_storage(tmp_path / "base.mot", coordinates_table(body, *motion, "rajagopal"))
    base = path.read_text()
    swaps = [("inDegrees=yes", "inDegrees=no"), ("inDegrees=yes", "inDegrees=maybe"),
             ("endheader", "end"), ("time", "Time"), ("pelvis_tx", "pelvis_tx\tpelvis_tx"),
             ("knee_angle_r", "knee_angle_l")]  # fmt: skip

    def case(rng, i):
        text, what = mutate_text(base, rng, swaps)
        path = write(tmp_path / f"{i}.mot", text)

        def fn():
            table = read_storage(path)
            return configurations(body, table)

        return what, fn, lambda r: finite(r[0], r[1])

    run_cases("storage (.mot coordinates)", 250, case)


def test_fuzz_loads(tmp_path):
    lines = (TRIALS / "subject01_walk1_grf.mot").read_text().splitlines()
    base = "\n".join(lines[:19]) + "\n"
    xml = (TRIALS / "subject01_walk1_grf.xml").read_text()
    swaps = [("ground_force_vy", "ground_force_v"), ("1_ground", "2_ground"),
             ("ground_torque", "ground_moment"), ("nRows=1501", "nRows=-1")]  # fmt: skip

    def case(rng, i):
        text, what = mutate_text(base, rng, swaps)
        folder = tmp_path / str(i)
        folder.mkdir()
        path = write(folder / "grf.mot", text)
        if rng.random() < 0.3:
            xml_text, more = mutate_text(xml, rng)
            what += f", xml {more}"
        else:
            xml_text = xml
        write(folder / "grf.xml", xml_text)
        return what, lambda: read_loads(path), finite

    run_cases("loads (.mot and .xml)", 300, case)


def test_fuzz_bvh(tmp_path, body, motion):
    base = write_bvh(tmp_path / "base.bvh", body, motion[0][:4], motion[1][:4]).read_text()
    swaps = [("Zrotation", "Wrotation"), ("Xposition", "Xrotation"), ("CHANNELS 3", "CHANNELS 2"),
             ("Frame Time:", "Frame Time: 0"), ("ROOT", "JOINT"), ("{", ""),
             ("End Site", "")]  # fmt: skip

    def case(rng, i):
        text, what = mutate_text(base, rng, swaps)
        path = write(tmp_path / f"{i}.bvh", text)
        return what, lambda: read_bvh(path), _markers_ok

    run_cases("BVH", 400, case)


# -- keypoints and cameras -------------------------------------------------------------------
def _cameras():
    return [cam.look_at("front", (4.0, 0.0, 1.2), (0.0, 0.0, 1.0)),
            cam.look_at("side", (0.0, 4.0, 1.2), (0.0, 0.0, 1.0))]  # fmt: skip


def test_fuzz_calibration(tmp_path):
    base = cam.write_calibration(tmp_path / "base.toml", _cameras()).read_text()
    point = np.array([[0.1, 0.2, 1.0]])

    def case(rng, i):
        text, what = mutate_text(base, rng)
        path = write(tmp_path / f"{i}.toml", text)

        def fn():  # (a point behind a camera projects to NaN: said in Camera.project)
            return [c.project(point) for c in cam.read_calibration(path) if c.depth(point)[0] > 0]

        return what, fn, finite

    run_cases("camera calibration (TOML)", 400, case)


def test_fuzz_openpose(tmp_path):
    rng0 = np.random.default_rng(0)
    uv = rng0.uniform(100, 900, (2, 3, 17, 2))
    conf = rng0.uniform(0.5, 1.0, (2, 3, 17))
    base = tmp_path / "base"
    files = [p for d in cam.write_openpose(base, uv, conf, ["front", "side"])
             for p in sorted(d.glob("*.json"))]  # fmt: skip
    texts = {p: p.read_text() for p in files}

    def case(rng, i):
        for p, t in texts.items():  # back to the valid files
            p.write_text(t)
        victim = files[int(rng.integers(0, len(files)))]
        what = victim.name
        if rng.random() < 0.1:
            victim.unlink()
            what += " deleted"
        else:
            text, more = mutate_text(texts[victim], rng)
            write(victim, text)
            what += f" {more}"
        layout = "coco17" if rng.random() < 0.9 else str(rng.choice(["body25", "nope", ""]))
        rate = 30.0 if rng.random() < 0.9 else float(rng.choice([0.0, -1.0, np.nan, 1e9]))

        def fn():
            k = cam.read_openpose(base, layout, rate)
            return k.time, k.confidence, np.where(np.isnan(k.uv), 0.0, k.uv)

        return f"{what}, {layout}, {rate}", fn, finite

    run_cases("keypoints (OpenPose JSON)", 100, case)


def test_fuzz_keypoint_arrays(tmp_path):
    rng0 = np.random.default_rng(1)
    points = rng0.uniform(-0.3, 1.7, (6, 17, 3))
    time = np.arange(6) / 30.0

    def case(rng, i):
        p, t, what = points.copy(), time.copy(), []
        kind = int(rng.integers(0, 7))
        if kind == 0:
            p.flat[rng.integers(0, p.size, 3)] = float(rng.choice([np.nan, np.inf, 1e300, -1e9]))
            what.append("bad point")
        elif kind == 1:
            t[rng.integers(0, 6)] = float(rng.choice([np.nan, np.inf, -1.0, 0.0, 1e300]))
            what.append("bad time")
        elif kind == 2:
            p = p[:, : int(rng.integers(0, 17))]
            what.append("fewer points")
        elif kind == 3:
            p = p.reshape(-1)[: int(rng.integers(0, p.size))]
            what.append("flat")
        elif kind == 4:
            t = t[: int(rng.integers(0, 6))]
            what.append("short time")
        elif kind == 5:
            p = np.array([["a"] * 3] * 17 * 6).reshape(6, 17, 3)
            what.append("strings")
        suffix = ".npz" if rng.random() < 0.6 else ".npy"
        path = tmp_path / f"{i}{suffix}"
        if suffix == ".npz":
            arrays = {"points": p, "time": t}
            if rng.random() < 0.15:
                del arrays[str(rng.choice(["points", "time"]))]
                what.append("a key deleted")
            np.savez(path, **arrays)
        else:
            np.save(path, p)
        if rng.random() < 0.1:
            blob = path.read_bytes()
            path.write_bytes(blob[: int(rng.integers(0, len(blob)))])
            what.append("truncated")
        rate = None if rng.random() < 0.8 else float(rng.choice([0.0, -30.0, np.nan, 1e9, 60.0]))
        args = argparse.Namespace(layout="coco17", rate=rate, y_up=bool(rng.random() < 0.5))
        return ", ".join(what) or "valid", lambda: markers_file(path, args), _markers_ok

    run_cases("keypoints (.npy/.npz)", 300, case)


# -- marker sets, maps, studies, scenes ----------------------------------------------------
def test_fuzz_marker_sets(tmp_path, body):
    placed = write_markers(tmp_path / "placed.toml", default_markers(body)).read_text()
    landmarks = (MARKERS / "default.toml").read_text()
    landmarks = "\n".join(x for x in landmarks.splitlines() if not x.startswith("#"))
    q = body.standing_configuration()[None]

    def case(rng, i):
        kind = "placed" if rng.random() < 0.6 else "landmarks"
        text, what = mutate_text(placed if kind == "placed" else landmarks, rng)
        path = write(tmp_path / f"{i}.toml", text)

        def fn():
            ms = read_markers(path) if kind == "placed" else default_markers(body, path)
            return marker_positions(body, q, ms)

        return f"{kind} {what}", fn, finite

    run_cases("marker sets (TOML)", 300, case)


MAP = """name = "fuzz"
[root]
rotation = ["pelvis_tilt", "pelvis_list", "pelvis_rotation"]
rotation_axes = ["-y", "x", "z"]
translation = ["pelvis_tx", "pelvis_ty", "pelvis_tz"]
translation_axes = ["x", "z", "-y"]
offset = [-0.0707, 0.0, -0.0661]
[joints.right_knee]
columns = ["knee_angle_r"]
signs = [-1]
[joints.right_hip]
columns = ["hip_flexion_r", "hip_adduction_r", "hip_rotation_r"]
axes = ["-y", "x", "z"]
"""


def test_fuzz_maps(tmp_path, body, motion):
    table = read_storage(
        write_storage(tmp_path / "c.mot", coordinates_table(body, *motion, "rajagopal"))
    )

    def case(rng, i):
        text, what = mutate_text(MAP, rng, [("-y", "y"), ("x", "w"), ("signs", "axes")])
        path = write(tmp_path / f"{i}.toml", text)
        return what, lambda: configurations(body, table, read_map(path)), finite

    run_cases("maps (TOML)", 250, case)


def test_fuzz_studies(tmp_path):
    folder = Path(hm.__file__).parent / "data" / "studies"
    # (push_standing's 750 runs cost 1 s a case to check: its smaller siblings do)
    bases = [(folder / f"{n}.toml").read_text() for n in ("push_slice", "walk_speed")]

    def case(rng, i):
        text, what = mutate_text(bases[i % len(bases)], rng)
        path = write(tmp_path / f"{i}.toml", text)
        return what, lambda: load_study(path), None

    run_cases("study files", 200, case)


SCENES = {n: tomllib.loads(hm.data.scene_path(n).read_text())
          for n in ("standing", "push", "tumble", "drop")}  # fmt: skip


def _leaves(d, prefix=()):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, (*prefix, k))
        else:
            yield (*prefix, k)


def test_fuzz_scene_values():
    """Scene.from_dict on mutated scenes (validation only: tests/test_fuzz.py runs them)."""
    import copy

    names = sorted(SCENES)
    values = [float("nan"), float("inf"), -1.0, 0.0, 1e300, 10**30, -(10**30), "x", None,
              True, [], {}, [1.0, 2.0], [float("nan")] * 3, 1e-300]  # fmt: skip

    def case(rng, i):
        doc = copy.deepcopy(SCENES[names[i % len(names)]])
        what = []
        for _ in range(int(rng.integers(1, 4))):
            path = list(_leaves(doc))
            if not path:
                break
            key = path[int(rng.integers(0, len(path)))]
            parent = doc
            for k in key[:-1]:
                parent = parent[k]
            op = rng.random()
            if op < 0.2:
                del parent[key[-1]]
                what.append(f"del {'.'.join(map(str, key))}")
            elif op < 0.3:
                parent[key[-1] + "_2"] = parent[key[-1]]
                what.append(f"dup {'.'.join(map(str, key))}")
            else:
                parent[key[-1]] = values[int(rng.integers(0, len(values)))]
                what.append(f"{'.'.join(map(str, key))} = {parent[key[-1]]!r}")
        return "; ".join(what), lambda: hm.Scene.from_dict(doc), finite

    run_cases("scenes (values)", 500, case)


# -- C3D -----------------------------------------------------------------------------------
C3D_CASES = cases(400)


@pytest.fixture(scope="module")
def c3d_base(tmp_path_factory):
    """A small C3D trial: 3 markers (a foot's), one type 2 plate, two events (ezc3d)."""
    import ezc3d

    c = ezc3d.c3d()
    frames = 20
    point = c["parameters"]["POINT"]
    point["RATE"]["value"] = np.array([100.0])
    point["UNITS"]["value"] = ["mm"]
    point["LABELS"]["value"] = ["RHEE", "RTOE", "LHEE"]
    pts = np.zeros((4, 3, frames))
    pts[3] = 1.0
    pts[0] = np.array([[0.0], [200.0], [0.0]]) + np.arange(frames) * 5.0
    pts[1] = np.array([[0.0], [0.0], [150.0]])
    pts[2] = np.array([[50.0], [50.0], [50.0]])
    c["data"]["points"] = pts
    analog = c["parameters"]["ANALOG"]
    analog["RATE"]["value"] = np.array([200.0])
    analog["LABELS"]["value"] = ["Fx", "Fy", "Fz", "Mx", "My", "Mz"]
    analog["UNITS"]["value"] = ["N", "N", "N", "Nmm", "Nmm", "Nmm"]
    signals = np.zeros((6, frames * 2))
    signals[2] = -700.0 * np.sin(np.linspace(0, np.pi, frames * 2))
    c["data"]["analogs"] = signals[None]
    fp = c["parameters"]["FORCE_PLATFORM"]
    fp["USED"]["value"] = np.array([1])
    fp["TYPE"]["value"] = np.array([2])
    corners = np.array([[300, 300, -300, -300], [200, -200, -200, 200], [0, 0, 0, 0]], float)
    fp["CORNERS"]["value"] = corners[:, :, None]
    fp["ORIGIN"]["value"] = np.array([[0.0], [0.0], [-40.0]])
    fp["CHANNEL"]["value"] = np.arange(1, 7).reshape(6, 1)
    c.add_event([0, 0.05], context="Right", label="Foot Strike")
    c.add_event([0, 0.15], context="Right", label="Foot Off")
    path = tmp_path_factory.mktemp("c3d") / "base.c3d"
    c.write(str(path))
    assert outcome(lambda: read_c3d(path), _markers_ok) == "finite"
    return path


def test_fuzz_c3d_in_a_child_process(tmp_path, c3d_base):
    out = tmp_path / "c3d.jsonl"
    argv = [sys.executable, str(HERE / "fuzz_c3d_worker.py"), str(c3d_base), str(C3D_CASES),
            str(out)]  # fmt: skip
    case = out.with_suffix(".case")
    try:
        done = subprocess.run(argv, capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the C3D worker hung on {case.read_text() if case.exists() else '?'}")
    assert done.returncode == 0, (
        f"the C3D worker died (exit {done.returncode}) on "
        f"{case.read_text() if case.exists() else '?'}\n{done.stderr[-3000:]}"
    )
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    counts = COUNTS.setdefault("C3D", Counter())
    for r in rows:
        counts[r["result"].split(":")[0]] += 1
    bad = [r for r in rows if r["result"] not in ("finite", "typed")]
    FAILURES["C3D"] = [json.dumps(r) for r in bad]
    assert len(rows) == C3D_CASES
    assert not bad, bad[:10]


# -- the command line ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cli_files(tmp_path_factory, body, motion, c3d_base):
    """Small files, valid and not, for the commands to refuse or read."""
    d = tmp_path_factory.mktemp("cli")
    t, q = motion
    t30, q30 = np.arange(30) / 60.0, np.repeat(q, 4, axis=0)[:30]  # (id filters: 10 at least)
    markers = {k: v for k, v in default_markers(body).items() if "." in k}
    positions = marker_positions(body, q[:3], markers)
    files = {
        "trc": write_trc(d / "m.trc", MarkerTrajectories(t[:3], list(markers), positions)),
        "mot": write_storage(d / "c.mot", coordinates_table(body, t30, q30, "rajagopal")),
        "c3d": c3d_base,
        "empty.trc": write(d / "empty.trc", ""),
        "bad.mot": write(d / "bad.mot", "x\nendheader\ntime\tknee\n0\tnan\n"),
        "bad.c3d": write(d / "bad.c3d", "not a c3d"),
        "bad.npz": write(d / "bad.npz", "PK"),
        "bad.toml": write(d / "bad.toml", "[[["),
        "none.trc": d / "missing.trc",
        "bvh": write_bvh(d / "m.bvh", body, t[:3], q[:3]),
        "kp.npy": d / "kp.npy",
        "study": write(
            d / "s.toml",
            (Path(hm.__file__).parent / "data" / "studies" / "push_slice.toml").read_text(),
        ),  # fmt: skip
        "calib": cam.write_calibration(d / "cal.toml", _cameras()),
    }
    np.save(files["kp.npy"], np.full((3, 17, 3), np.nan))
    return files


# the commands that run long on good input get only input they refuse: a case is a typed
# refusal or a small result, never a walk or a sweep
CHEAP_OK = {"id", "loads", "variants", "ik", "info", "build", "export"}
OPTIONS = {
    "ik": ["--height", "--mass", "--sex", "--model", "--marker-set", "--smoothing", "--static",
           "--layout", "--rate", "--map", "-o", "--save-markers", "--calibration"],
    "scale": ["--mass", "--mode", "--fit-frames", "--height", "--sex", "--model",
              "--marker-set", "--time-range", "-o"],
    "track": ["--loads", "--loads-xml", "--loads-side", "--map", "--cutoff", "--dt", "-o",
              "--floor", "--layout", "--rate"],
    "id": ["--loads", "--loads-xml", "--loads-side", "--markers", "--marker-set", "--map",
           "--cutoff", "--velocity", "--rate", "-o", "--reduced", "--height", "--mass"],
    "loads": ["-o", "--threshold", "--plate-side"],
    "report": ["--moments", "--loads", "--events", "--height", "--mass", "--sex", "--model",
               "--map", "--speed", "--threshold", "--marker-set", "-o"],
    "sweep": ["-o", "--workers", "--scheduler"],
    "bench": ["-o"],
    "variants": [],
}  # fmt: skip
POSITIONALS = {
    "ik": ["trc", "c3d", "bvh", "kp.npy", "empty.trc", "bad.c3d", "bad.npz", "none.trc"],
    "scale": ["empty.trc", "bad.c3d", "none.trc", "bad.mot"],
    "track": ["bad.mot", "empty.trc", "bad.npz", "none.trc", "bad.c3d"],
    "id": ["mot", "bad.mot", "empty.trc", "bad.npz", "none.trc"],
    "loads": ["c3d", "bad.c3d", "none.trc", "trc"],
    "report": ["bad.mot", "bad.c3d", "none.trc", "empty.trc"],
    "sweep": ["bad.toml", "none.trc", "study"],
    "bench": ["nonsense", "step"],
    "variants": ["x"],
}
EXPENSIVE = {"trc", "c3d", "bvh", "mot"}
WORDS = [*BAD_NUMBERS[:10], "1.75", "70", "male", "adult_male", "rajagopal", "coco17", "auto",
         "static", "left", "1=left", "PREFIX=up", "/proc/nope/x", "plugin-gait", "mot", "trc",
         "c3d", "bad.toml", "calib", "1", "0.5"]  # fmt: skip


def test_fuzz_command_line_motion(tmp_path, monkeypatch, cli_files):
    """Every motion command, sweep and bench with mutated arguments, in this process."""
    monkeypatch.chdir(tmp_path)
    names = sorted(OPTIONS)

    def word(rng):
        w = WORDS[int(rng.integers(0, len(WORDS)))]
        return str(cli_files.get(w, w))

    def case(rng, i):
        command = names[i % len(names)]
        argv = [command]
        if rng.random() < 0.9:
            files = POSITIONALS[command]
            if rng.random() > 0.1:  # a valid motion (an IK, an ID) in one case in ten
                files = [f for f in files if f not in EXPENSIVE] or files
            argv.append(str(cli_files.get(p := str(rng.choice(files)), p)))
        for _ in range(int(rng.integers(0, 4))):
            if OPTIONS[command] and rng.random() < 0.85:
                argv += [str(rng.choice(OPTIONS[command])), word(rng)]
            else:
                argv.append(word(rng))
        if command in ("ik", "id", "track", "scale", "report"):
            argv += ["-o", str(tmp_path / f"out{i}.{'urdf' if command == 'scale' else 'sto'}")]
        if command == "sweep":
            argv += ["--list", "--quiet"]
        if command == "bench":
            argv += ["-o", "/proc/nope/bench"]  # refused before any benchmark runs
        if command == "scale":
            argv += ["--mass", "70"] if "--mass" not in argv else []

        def fn():
            out, err = io.StringIO(), io.StringIO()
            try:
                with redirect_stdout(out), redirect_stderr(err):
                    code = main(argv)
            except SystemExit as exc:  # argparse: a usage error (2), --help (0)
                code = exc.code
            if code not in (0, 2, 3) or "Traceback" in err.getvalue():
                raise AssertionError(f"exit {code}: {err.getvalue()[-300:]}")
            return code

        return " ".join(argv[:1] + [Path(a).name for a in argv[1:]]), fn, None

    run_cases("command line (motion, sweep, bench)", 120, case, seconds=20.0)


# the expensive entry points, a handful of tiny cases: a valid run (its exit code; None: no
# valid run, a report costs 4 s), then one value made bad (exit 2, refused before the work)
HANDFUL = [
    ("ik", "trc", [], 0, "--smoothing", "nan"),
    ("ik", "bvh", [], 0, "--rate", "-1"),
    ("id", "mot", [], 0, "--cutoff", "inf"),
    ("report", "mot", ["-o", "report.png"], None, "--speed", "nan"),
    ("loads", "c3d", ["--threshold", "1"], 0, "--threshold", "nan"),
]


@pytest.mark.parametrize(("command", "file", "extra", "valid", "option", "bad"), HANDFUL)
def test_fuzz_expensive_commands_a_handful(tmp_path, monkeypatch, cli_files, command, file,
                                           extra, valid, option, bad):  # fmt: skip
    monkeypatch.chdir(tmp_path)
    out = [] if command in ("report", "loads") else ["-o", str(tmp_path / "out.sto")]
    argv = [command, str(cli_files[file]), *extra, *out]
    if command in ("ik", "id"):
        argv += ["--figure", str(tmp_path / "f.png")]
    counts = COUNTS.setdefault("command line (expensive, a handful)", Counter())
    runs = [(argv, valid)] if valid is not None else []
    for args, want in (*runs, ([*argv, option, bad], 2)):
        said = []

        def fn(args=args, said=said):
            err = io.StringIO()
            with redirect_stdout(io.StringIO()), redirect_stderr(err):
                code = main(args)
            said.append(err.getvalue())
            return code

        result = outcome(fn, lambda code, want=want: code == want, seconds=60.0)
        counts[result.split(":")[0]] += 1
        assert result == "finite", (args, result, said)
    if command in ("ik", "id"):  # what the valid run wrote is finite
        table = read_storage(tmp_path / "out.sto")
        assert finite(table.data)
