"""The symbolic model's checks (``tests/casadi_checks.py``), run in their own process.

OpenSim's wheel bundles its own casadi libraries and points LD_LIBRARY_PATH at them when it is
imported; casadi's Python package and OpenSim then cannot share a process (either import order
fails with an undefined symbol). The OpenSim peer's tests import OpenSim in this process, so
the casadi checks run in a child whose LD_LIBRARY_PATH leaves OpenSim's folder out, started as
soon as the session has collected them so that they run beside the rest of the suite.
"""

from __future__ import annotations

import pytest
from conftest import CHILDREN, start_checks

# the gait checks (optimal control and walks, about ten minutes of CPU) in six chunks, which
# pytest-xdist's workers share out (in three, one chunk took 14 minutes of a 36-minute run)
CHUNKS = [("casadi_checks.py", "0/1")] + [("casadi_gait_checks.py", f"{i}/6") for i in range(6)]


@pytest.mark.parametrize(("checks", "chunk"), CHUNKS)
def test_the_optimal_control_layer_in_its_own_process(checks, chunk):
    # started when the session collected this test (conftest.pytest_collection_modifyitems),
    # or now (under pytest-xdist)
    child, out, err = CHILDREN.pop((checks, chunk), None) or start_checks(checks, chunk)
    try:
        child.wait(timeout=900)
    finally:
        if child.poll() is None:
            child.kill()
    out.seek(0)
    err.seek(0)
    stdout, stderr = out.read(), err.read()
    out.close()
    err.close()
    assert child.returncode == 0, stdout[-4000:] + stderr[-2000:]
    assert " passed" in stdout and "failed" not in stdout
