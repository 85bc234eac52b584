"""The README is part of the product: its snippets run, its facts match the project."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RUNNER = ROOT / "scripts" / "readme_snippets.py"
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _run(readme: Path):
    return subprocess.run([sys.executable, str(RUNNER), str(readme)], capture_output=True,
                          text=True, timeout=600)  # fmt: skip


def test_the_readme_python_snippets_run_as_written():
    done = _run(ROOT / "README.md")
    assert done.returncode == 0, done.stderr
    n = len(re.findall(r"```python\n", README))
    assert n >= 3
    assert f"{n} README snippets ran" in done.stdout


def test_the_snippet_runner_reports_a_broken_snippet(tmp_path):
    bad = tmp_path / "README.md"
    bad.write_text("```python\nx = 1\n```\n\n```python\nimport humanoid\nhumanoid.load(42)\n```\n")
    done = _run(bad)
    assert done.returncode == 1
    assert "snippet 2 of 2 failed" in done.stderr
    assert "ModelError" in done.stderr


def test_the_readme_python_version_matches_pyproject():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    need = re.search(r">=\s*([\d.]+)", meta["requires-python"]).group(1)
    stated = set(re.findall(r"Python >= (\d+\.\d+)", README))
    assert stated == {need}, stated


def test_the_readme_names_no_file_outside_the_repo():
    assert "shared/" not in README
    for path in re.findall(r"`((?:docs|humanoid|scripts|tests)/[\w./-]+)`", README):
        assert (ROOT / path).exists(), path


def test_the_speed_tables_are_the_benchmark_output():
    """The README's speed tables are the text `humanoid bench step -o docs/bench` wrote
    (`make bench` pastes it), with the machine and the date they were measured on."""
    import re

    block = README.split("<!-- speed: begin -->\n", 1)[1].split("<!-- speed: end -->", 1)[0]
    written = (ROOT / "docs" / "bench" / "speed.md").read_text()
    assert block == written, "README speed tables differ from docs/bench/speed.md: make bench"
    assert written.startswith("Measured by `humanoid bench step` on ")
    assert re.search(r"\d{4}-\d{2}-\d{2} \d{2}:\d{2} UTC", written), "no date"
    assert "| tumble |" in written and "| collapse |" in written
