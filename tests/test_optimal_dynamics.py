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

import pytest
from conftest import clean_library_path

HERE = Path(__file__).resolve().parent


@pytest.mark.parametrize("checks", ["casadi_checks.py", "casadi_gait_checks.py"])
def test_the_optimal_control_layer_in_its_own_process(checks):
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            str(HERE / checks),
        ],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=HERE.parent,
        env=clean_library_path(),
    )
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
    assert " passed" in done.stdout and "failed" not in done.stdout
