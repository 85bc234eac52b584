"""Shared fixtures: the bodies and models the tests run on, loaded once per session."""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin
import pytest

import humanoid as hm
from humanoid.data import BODIES, SCENES  # noqa: F401 - the tests import them from here


@pytest.fixture(scope="session")
def male_urdf() -> str:
    return hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male"))


@pytest.fixture(scope="session")
def female_urdf() -> str:
    return hm.build_urdf(hm.BodyParameters(1.62, 62.0, "female"))


_CACHE: dict = {}


def get_model(name: str, mode: str) -> hm.Humanoid:
    """A loaded model by short name: male, female, human (erd), talos (erd); male_foot: the
    male body with one-piece feet (``--no-toes``)."""
    key = (name, mode)
    if key not in _CACHE:
        if name == "male_foot":
            urdf = hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male", toes=False))
            _CACHE[key] = hm.load(urdf, ball_joints=mode)
        elif name == "male":
            _CACHE[key] = hm.load(BODIES / "adult_male.urdf", ball_joints=mode)
        elif name == "female":
            _CACHE[key] = hm.load(BODIES / "adult_female.urdf", ball_joints=mode)
        else:
            path, _ = hm.model.example_robot_path(name)
            _CACHE[key] = hm.load(path, ball_joints=mode)
    return _CACHE[key]


ALL_MODELS = [
    (name, mode)
    for name in ("male", "female", "human", "talos")
    for mode in ("euler", "quaternion")
]


def random_state(h: hm.Humanoid, rng: np.random.Generator, inside_limits: bool = True):
    """A random (q, v): joints uniform in their limits (clipped to +-2 rad), random base."""
    m = h.model
    q = h.standing_configuration()
    q[:3] += rng.normal(scale=0.3, size=3)
    q[3:7] = pin.Quaternion(pin.exp3(rng.normal(size=3))).coeffs()
    for jm in m.joints[2:]:
        if jm.nq == 1:
            lo = max(m.lowerPositionLimit[jm.idx_q], -2.0)
            hi = min(m.upperPositionLimit[jm.idx_q], 2.0)
            q[jm.idx_q] = rng.uniform(lo, hi) if inside_limits else rng.uniform(-2, 2)
        elif jm.nq == 4:
            q[jm.idx_q : jm.idx_q + 4] = pin.Quaternion(pin.exp3(rng.normal(size=3))).coeffs()
    v = rng.normal(size=m.nv)
    return q, v


# every process this test session starts carries this tag in its environment (an orphan
# keeps it): the viewer-process checks look at this session's servers only, not at another
# pytest-xdist worker's or another run's on the same machine
TAG = f"{os.getpid()}-{os.environ.get('PYTEST_XDIST_WORKER', 'main')}"
os.environ["HUMANOID_TEST_SESSION"] = TAG


def viewer_servers() -> list[str]:
    """The meshcat servers (``humanoid._meshcat_server``) this test session started that
    still run (zombies aside): "pid command" each."""
    out = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                args = f.read().replace(b"\0", b" ").decode(errors="replace")
            if "humanoid._meshcat_server" not in args:
                continue
            with open(f"/proc/{pid}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] == "Z":
                    continue
            with open(f"/proc/{pid}/environ", "rb") as f:
                if f"HUMANOID_TEST_SESSION={TAG}".encode() not in f.read().split(b"\0"):
                    continue
        except OSError:  # gone meanwhile, or not ours to read
            continue
        out.append(f"{pid} {args.strip()}")
    return out


@pytest.fixture(scope="session", autouse=True)
def no_viewer_process_outlives_the_tests():
    """After the whole session, no meshcat server started by the tests may still run."""
    yield
    import time

    for _ in range(50):
        left = viewer_servers()
        if not left:
            return
        time.sleep(0.1)
    raise AssertionError(f"viewer processes left after the tests: {left}")


def landing_run(duration: float):
    """The male body dropped from 5 cm onto unilateral welds, holding its posture: the feet
    move, land (touchdown impulses), then carry the body. Shared by the viewer tests."""
    from humanoid.scene import Contact, Controller, Effects, Initial, Scene

    q0 = get_model("male", "quaternion").standing_configuration()
    q0[2] += 0.05
    feet = (Contact("left", unilateral=True), Contact("right", unilateral=True))
    scene = Scene(
        body=str(BODIES / "adult_male.urdf"),
        duration=duration,
        dt=1e-3,
        initial=Initial(configuration=tuple(q0)),
        effects=Effects(contacts=feet),
        controller=Controller("posture", frequency=8.0),
    )
    return hm.simulate(scene, quiet=True)


def assert_heel_to_toe(analysis, strikes: int, stances: int, slip: float = 2e-3) -> None:
    """A walk's gait analysis: at least ``strikes`` heel strikes and ``stances`` analysed
    stances, every one heel strike, foot flat, heel off and toe off, its loaded points sliding
    under ``slip`` [m]."""
    from humanoid.model import SIDES

    assert sum(len(analysis.events[s]["strike"]) for s in SIDES) >= strikes, analysis.events
    feet = [f for s in SIDES for f in analysis.feet[s]]
    assert len(feet) >= stances, feet
    for f in feet:
        assert f["heel_strike"] and f["flat"] and f["heel_off"] and f["toe_off"], f
        assert f["slip"] < slip, f


@pytest.fixture(scope="session")
def walk_1khz():
    """Two steps of the male body's walk at 0.8 m/s, every simulation step recorded (the motion
    tests' and the OpenSim peer's), and the body that walked it (its toes locked)."""
    from humanoid.walking.gait import walk_on_ground

    h = hm.load(BODIES / "adult_male.urdf")
    walk = walk_on_ground(h, speed=0.8, steps=2, record_rate=1000.0)
    assert walk.trajectory.status == "completed"
    return walk.body, walk.trajectory  # (the body walked the fitted cycle, its toes locked)


def clean_library_path() -> dict:
    """This process's environment without the OpenSim folder that ``import opensim`` puts on
    LD_LIBRARY_PATH (its bundled casadi breaks casadi's Python package in a child)."""
    import os

    env = dict(os.environ)
    parts = [
        p for p in env.get("LD_LIBRARY_PATH", "").split(os.pathsep) if p and "opensim" not in p
    ]
    env["LD_LIBRARY_PATH"] = os.pathsep.join(parts)
    return env


# -- the casadi checks' child processes (tests/test_optimal_dynamics.py) --------------------
# Each (file, chunk) runs in a child pytest that collects the file and keeps every N-th test
# (HUMANOID_CHECKS_CHUNK="i/N", read by pytest_collection_modifyitems in the child). Run alone,
# the session starts them all as soon as it has collected them, so that they run on the second
# core beside the rest of the suite; under pytest-xdist (every worker collects every test) each
# starts in the worker that runs its test, and the workers balance the chunks.
CHILDREN: dict = {}
CHUNK = "HUMANOID_CHECKS_CHUNK"


def start_checks(checks: str, chunk: str = "0/1"):
    """A child pytest running chunk ``chunk`` ("i/N") of ``tests/<checks>`` with its output in
    temporary files."""
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    here = Path(__file__).resolve().parent
    out, err = tempfile.TemporaryFile("w+"), tempfile.TemporaryFile("w+")
    child = subprocess.Popen(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
         str(here / checks)],
        stdout=out, stderr=err, text=True, cwd=here.parent,
        env=clean_library_path() | {CHUNK: chunk},
    )  # fmt: skip
    return child, out, err


def pytest_collection_modifyitems(session, config, items):
    import os

    chunk = os.environ.get(CHUNK)
    if chunk:  # a child: its share of the checks
        i, n = (int(x) for x in chunk.split("/"))
        items[:] = [item for k, item in enumerate(items) if k % n == i]
        return
    # the children first: the longest tests, started before the rest rather than after it
    items.sort(key=lambda item: item.path.name != "test_optimal_dynamics.py")
    if os.environ.get("PYTEST_XDIST_WORKER"):
        return  # (started by the test, in the worker that runs it)
    for item in items:
        callspec = getattr(item, "callspec", None)
        if item.path.name == "test_optimal_dynamics.py" and callspec is not None:
            key = callspec.params["checks"], callspec.params["chunk"]
            CHILDREN.setdefault(key, start_checks(*key))


def pytest_sessionfinish(session, exitstatus):
    for child, out, err in CHILDREN.values():
        if child.poll() is None:
            child.kill()
            child.wait()
        out.close()
        err.close()
    CHILDREN.clear()
