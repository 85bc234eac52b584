"""The planted-bug harness's table (scripts/mutation.py) applies to the code as it is: every
old text occurs exactly once in its file, each change is one line and changes the text, and
every test it names exists. (The measurement itself runs the tests: `python
scripts/mutation.py`, about an hour; not part of `make test`.)"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _harness():
    spec = importlib.util.spec_from_file_location(
        "mutation_harness", ROOT / "scripts" / "mutation.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # (dataclasses look their module up)
    spec.loader.exec_module(module)
    return module


def test_the_planted_bugs_apply_exactly_once():
    harness = _harness()
    assert len(harness.MUTATIONS) >= 66
    assert harness.check_table(ROOT) == []
    files = {m.file for m in harness.MUTATIONS}
    assert len(files) >= 30  # spread over the package, not piled in one module
