"""Fuzzing the public entry points (hypothesis, seeded): bad input never crashes and never lies.

Six categories, as a user's bad input arrives: body parameters, mutated URDFs (in a child
process: an interpreter crash must be seen, not suffered), mutated TOML scenes, bad states,
corrupt run files and command-line arguments. Each case must end in a result whose numbers are
finite or in a :class:`humanoid.HumanoidError` (argparse's own usage error, exit 2, for the
command line); anything else fails. The counts are printed (``pytest -s``) and kept in
``results/fuzz.json``.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
import tomllib
import zipfile
from collections import Counter
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from conftest import get_model
from fuzz_tools import SEED, cases, seeded
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import humanoid as hm
from humanoid.cli import main

HERE = Path(__file__).resolve().parent
COUNTS: dict[str, Counter] = {}
FUZZ = settings(
    derandomize=True, deadline=None, database=None, suppress_health_check=list(HealthCheck)
)


def fuzz(n: int):
    """Seeded (derandomised; :data:`~fuzz_tools.SEED`'s seed, if set), n cases (times
    :data:`~fuzz_tools.SCALE`), no deadline: a few cases load a body."""

    def decorate(test):
        return seeded(settings(FUZZ, max_examples=cases(n), derandomize=not SEED)(test))

    return decorate


junk_number = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**400), 10**400),
    st.sampled_from([0, -1, 1e-300, 1e300, 10**400]),
)
junk = st.one_of(
    junk_number,
    st.text(max_size=6),
    st.none(),
    st.booleans(),
    st.lists(st.floats(), max_size=4),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
)


def tally(category: str, outcome: str) -> None:
    COUNTS.setdefault(category, Counter())[outcome] += 1


def all_finite(*values) -> bool:
    for v in values:
        a = np.asarray(v, dtype=float)
        if not np.all(np.isfinite(a)):
            return False
    return True


@pytest.fixture(scope="module", autouse=True)
def report():
    yield
    out = HERE.parent / "results" / "fuzz.json"
    out.parent.mkdir(exist_ok=True)
    table = {k: dict(v) for k, v in sorted(COUNTS.items())}
    out.write_text(json.dumps(table, indent=1))
    print("\nfuzz counts:", json.dumps(table))


# -- 1. body parameters ------------------------------------------------------------------------
def mostly(data, valid, bad=junk):
    """A valid value three times in four, else junk."""
    return data.draw(valid if data.draw(st.integers(0, 3)) else bad)


@fuzz(120)
@given(data=st.data())
def test_fuzz_body_parameters(data):
    height = mostly(
        data, st.floats(0.5, 2.5), st.one_of(junk, st.floats(2.5, 3), st.floats(0, 0.5))
    )
    mass = mostly(data, st.floats(10, 300))
    sex = mostly(data, st.sampled_from(["male", "female"]))
    names = st.sampled_from(["thigh", "shank", "head", "tail", "ankle_height"])
    lengths = mostly(data, st.one_of(st.none(), st.dictionaries(names, st.floats(0.02, 0.6),
                                                                max_size=2)))  # fmt: skip
    try:
        p = hm.BodyParameters(height, mass, sex, lengths)
        urdf = hm.build_urdf(p)  # (a foot the toes outweigh is refused here)
    except hm.HumanoidError:
        tally("body parameters", "typed error")
        return
    h = hm.load(urdf)
    assert h.mass == pytest.approx(p.mass, rel=1e-9)
    assert all_finite(hm.centre_of_mass(h, h.standing_configuration()))
    tally("body parameters", "built")


# -- 2. URDFs, in a child process ----------------------------------------------------------------
def test_fuzz_urdfs_in_a_child_process(tmp_path):
    out = tmp_path / "urdf.jsonl"
    done = subprocess.run(
        [sys.executable, str(HERE / "fuzz_urdf_worker.py"), str(cases(400)), str(out)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    case = out.with_suffix(".case")
    assert done.returncode == 0, (
        f"the URDF worker died (exit {done.returncode}) on this case:\n"
        f"{case.read_text()[:3000] if case.exists() else '?'}\n{done.stderr[-3000:]}"
    )
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(rows) >= cases(300)
    for r in rows:
        tally("URDFs", r["result"].split(":")[0])
    bad = [r for r in rows if not r["result"].startswith(("typed", "loaded"))]
    assert not bad, bad[:5]


# -- 3. scenes -------------------------------------------------------------------------------------
SCENES = {
    name: tomllib.loads(hm.data.scene_path(name).read_text())
    for name in ("standing", "push", "tumble", "drop")
}


def _paths(d, prefix=()):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _paths(v, (*prefix, k))
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for i, item in enumerate(v):
                yield from _paths(item, (*prefix, k, i))
        else:
            yield (*prefix, k)


def _set(d, path, value):
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value


@fuzz(150)
@given(name=st.sampled_from(sorted(SCENES)), data=st.data())
def test_fuzz_scenes(tmp_path_factory, name, data):
    import copy

    doc = copy.deepcopy(SCENES[name])
    paths = list(_paths(doc))
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(paths))
        value = data.draw(
            st.one_of(
                st.floats(-10, 10),
                st.floats(1e-4, 10),
                junk_number,
                st.text(max_size=5),
                st.booleans(),
                st.lists(junk_number, max_size=7),
                st.just({}),
            )
        )
        try:
            _set(doc, path, value)
        except (KeyError, TypeError, IndexError):
            pass
    if data.draw(st.booleans()):
        doc[data.draw(st.sampled_from(["effects", "initial", "nonsense"]))] = {"x": 1}
    text = hm.scene._toml(doc)
    path = tmp_path_factory.mktemp("scene") / "s.toml"
    path.write_text(text)
    try:
        scene = hm.Scene.load(path)
        scene = scene.replace(duration=min(scene.duration, 5 * scene.dt), record_rate=1 / scene.dt)
        traj = hm.simulate(scene, quiet=True)
    except hm.HumanoidError:
        tally("scenes", "typed error")
        return
    assert all_finite(traj.q, traj.v, traj.energy)
    tally("scenes", traj.status)


# -- 4. states -------------------------------------------------------------------------------------
@fuzz(250)
@given(data=st.data(), which=st.sampled_from(["male", "talos"]))
def test_fuzz_states(data, which):
    h = get_model(which, "quaternion")
    q0 = h.standing_configuration()
    q = data.draw(
        st.one_of(
            st.lists(junk_number, min_size=h.nq, max_size=h.nq),
            st.lists(st.floats(-10, 10), min_size=h.nq, max_size=h.nq),
            st.just(q0 + 0.0),
            junk,
            st.lists(st.floats(-1e7, 1e7), min_size=h.nq - 1, max_size=h.nq + 1),
        )
    )
    v = data.draw(
        st.one_of(
            st.lists(junk_number, min_size=h.nv, max_size=h.nv),
            st.lists(st.floats(-1e3, 1e3), min_size=h.nv, max_size=h.nv),
            junk,
        )
    )
    try:
        out = [
            hm.mass_matrix(h, q),
            hm.gravity_forces(h, q),
            hm.potential_energy(h, q),
            hm.bias_forces(h, q, v),
            hm.kinetic_energy(h, q, v),
            *hm.centroidal_momentum(h, q, v),
            hm.centre_of_mass(h, q),
        ]
    except hm.HumanoidError:
        tally("states", "typed error")
        return
    assert all_finite(*out)
    tally("states", "finite")


# -- 5. run files ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def saved_run(tmp_path_factory):
    traj = hm.simulate(hm.Scene.load("tumble").replace(duration=0.05), quiet=True)
    return traj.save(tmp_path_factory.mktemp("run") / "run.npz")


@fuzz(300)
@given(data=st.data())
def test_fuzz_run_files(tmp_path_factory, saved_run, data):
    saved = saved_run.read_bytes()
    kind = data.draw(st.sampled_from(["bytes", "truncate", "arrays", "metadata"]))
    path = tmp_path_factory.mktemp("npz") / "r.npz"
    if kind == "bytes":
        blob = bytearray(saved)
        for _ in range(data.draw(st.integers(1, 20))):
            blob[data.draw(st.integers(0, len(blob) - 1))] = data.draw(st.integers(0, 255))
        path.write_bytes(bytes(blob))
    elif kind == "truncate":
        path.write_bytes(saved[: data.draw(st.integers(0, len(saved)))])
    else:
        with np.load(io.BytesIO(saved)) as z:
            arrays = {k: z[k] for k in z.files}
        key = data.draw(st.sampled_from(sorted(set(arrays) - {"metadata"})))
        if kind == "metadata":
            arrays["metadata"] = np.array(
                data.draw(
                    st.sampled_from(
                        ["{", "[]", "null", '{"nq": "x"}', '{"body": {"urdf": 5}}', "1e400"]
                    )
                )
            )
        elif data.draw(st.booleans()):
            del arrays[key]
        else:
            a = arrays[key]
            arrays[key] = data.draw(
                st.sampled_from(
                    [
                        a[:-1],
                        a.astype(np.float32),
                        np.full_like(a, np.nan, dtype=float),
                        np.zeros((3, 3, 3)),
                        np.array("text"),
                        a.reshape(-1),
                    ]
                )
            )
        with zipfile.ZipFile(path, "w") as zf:
            for k, a in arrays.items():
                buf = io.BytesIO()
                np.save(buf, a, allow_pickle=False)
                zf.writestr(f"{k}.npy", buf.getvalue())
    try:
        traj = hm.Trajectory.load(path)
        from humanoid.viewer import humanoid_for

        h = humanoid_for(traj)
    except hm.HumanoidError:
        tally("run files", "typed error")
        return
    assert all_finite(traj.t, traj.q, traj.v, traj.energy)
    assert h.model.nq == traj.q.shape[1]
    tally("run files", "read")


# -- 6. the command line ---------------------------------------------------------------------------
VALUES = [
    "nan",
    "-1",
    "0",
    "1e400",
    "x",
    "",
    "1.75",
    "70",
    "adult_male",
    "talos",
    "nowhere.urdf",
    "push",
    "tumble",
    "/",
    "/proc/nope/out.npz",
    "male",
    "--",
    "-o",
    "2",
]
OPTIONS = [
    "--height",
    "--mass",
    "--sex",
    "--segment",
    "-o",
    "--ball-joints",
    "--massless",
    "--duration",
    "--steps",
    "--speed",
    "--step-length",
    "--mu",
    "--html",
    "--fps",
    "--force-scale",
    "--mjcf",
    "--quick",
    "--version",
    "--figure",
]


COMMANDS = ["build", "info", "simulate", "walk", "view", "export", "nonsense"]
POSITIONAL = {"info": "adult_male", "view": "adult_male", "export": "adult_male",
              "simulate": "tumble"}  # fmt: skip
argument = st.one_of(
    st.tuples(st.sampled_from(OPTIONS), st.sampled_from(VALUES)),  # an option and a value
    st.tuples(st.sampled_from(VALUES)),  # a stray word
)


@fuzz(150)
@given(command=st.sampled_from(COMMANDS), positional=st.booleans(),
       rest=st.lists(argument, max_size=4))  # fmt: skip
def test_fuzz_command_line(tmp_path_factory, monkeypatch, command, positional, rest):
    monkeypatch.chdir(tmp_path_factory.mktemp("cli"))
    argv = [command]
    if positional and command in POSITIONAL:
        argv.append(POSITIONAL[command])
    argv += [word for arg in rest for word in arg]
    # long runs and servers are not bad input: the last value of an option wins in argparse,
    # so these keep every case short (a walk of one step is refused, a view writes a file)
    argv += {
        "walk": ["--steps", "1"],
        "simulate": ["--duration", "nan"],
        "view": ["--html", "view.html"],
    }.get(command, [])
    out, err = io.StringIO(), io.StringIO()
    try:
        with redirect_stdout(out), redirect_stderr(err):
            code = main(argv)
    except SystemExit as exc:  # argparse: usage error (2), or --help/--version (0)
        assert exc.code in (0, 2), argv
        tally("command line", f"argparse exit {exc.code}")
        return
    assert code in (0, 2, 3), (argv, code)
    assert "Traceback" not in err.getvalue()
    tally("command line", f"exit {code}")
