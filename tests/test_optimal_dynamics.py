"""The symbolic model's checks (``tests/casadi_checks.py``), run in their own process.

OpenSim's wheel bundles its own casadi libraries and points LD_LIBRARY_PATH at them when it is
imported; casadi's Python package and OpenSim then cannot share a process (either import order
fails with an undefined symbol). The OpenSim peer's tests import OpenSim in this process, so
the casadi checks run in a child whose LD_LIBRARY_PATH leaves OpenSim's folder out.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from conftest import clean_library_path

HERE = Path(__file__).resolve().parent


def test_the_symbolic_model_equals_pinocchio():
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            str(HERE / "casadi_checks.py"),
        ],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=HERE.parent,
        env=clean_library_path(),
    )
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
    assert " passed" in done.stdout and "failed" not in done.stdout
