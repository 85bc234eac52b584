"""The README is part of the product: its snippets run, its facts match the project."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

from conftest import clean_library_path

ROOT = Path(__file__).resolve().parent.parent
RUNNER = ROOT / "scripts" / "readme_snippets.py"
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _run(readme: Path):
    # without OpenSim's LD_LIBRARY_PATH (set when another test imported it): its bundled casadi
    # would break the optimal-control snippet's
    return subprocess.run([sys.executable, str(RUNNER), str(readme)], capture_output=True,
                          text=True, timeout=600, env=clean_library_path())  # fmt: skip


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
    """The README's speed tables are the text `humanoid bench step|walk -o docs/bench` wrote
    (`make bench` pastes it), with the machine and the date they were measured on; their
    columns are the benchmarks' CSV columns, and their numbers those of the CSV files."""
    import csv
    import re

    from humanoid.bench.step import STEP_COLUMNS
    from humanoid.bench.walk import WALK_COLUMNS

    for name, file, command in (("speed", "speed.md", "step"), ("walk-speed", "walk.md", "walk")):
        block = README.split(f"<!-- {name}: begin -->\n", 1)[1].split(f"<!-- {name}: end -->")[0]
        written = (ROOT / "docs" / "bench" / file).read_text()
        assert block == written, f"README {name} tables differ from docs/bench/{file}: make bench"
        assert written.startswith(f"Measured by `humanoid bench {command}` on ")
        assert re.search(r"\d{4}-\d{2}-\d{2} \d{2}:\d{2} UTC", written), "no date"
    speed = (ROOT / "docs" / "bench" / "speed.md").read_text()
    assert "| tumble |" in speed and "| collapse |" in speed
    # the step table: its columns, in order, are step.csv's; its numbers are the CSV's
    with open(ROOT / "docs" / "bench" / "step.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == STEP_COLUMNS
    header = next(line for line in speed.splitlines() if line.startswith("| scene |"))
    cells = [c.strip() for c in header.strip("|").split("|")]
    assert cells == ["scene", "contacts", "Pinocchio", "native", "ratio", "reference KKT",
                     "ratio", "as shipped", "ratio"]  # fmt: skip
    for row in rows:
        line = next(x for x in speed.splitlines() if x.startswith(f"| {row['scene']} |"))
        shown = [c.strip() for c in line.strip("|").split("|")]
        p = float(row["pinocchio"])
        expect = [row["scene"], row["contacts"], f"{p * 1e6:.1f}"]
        for key in STEP_COLUMNS[3:]:
            expect += [f"{float(row[key]) * 1e6:.1f}", f"{float(row[key]) / p:.2f}"]
        assert shown == expect
    # the walk table: a row per control period with walk.csv's numbers
    walk = (ROOT / "docs" / "bench" / "walk.md").read_text()
    with open(ROOT / "docs" / "bench" / "walk.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == WALK_COLUMNS
    for row in rows:
        line = next(x for x in walk.splitlines() if x.startswith(f"| {row['control']} |"))
        shown = [c.strip() for c in line.strip("|").split("|")]
        assert shown[1] == f"{float(row['real_time_factor']):.1f}x"
        assert shown[2] == f"{float(row['ratio']):.1f}"
        assert shown[3] == f"{float(row['wall']) * 1e3:.1f}"
        assert shown[-1] == ("yes" if row["checks_passed"] == "True" else "no")


def test_the_study_results_are_the_sweeps_output():
    """The README's study results are the text `humanoid sweep push_standing|walk_speed` wrote
    (`make studies` copies it to docs/studies/ and pastes it), with the machine and the date;
    their figures are there; their tables are the reductions of the Parquet tables copied
    beside them, by the study files' figure sections."""
    from humanoid.study import load_study, read_table
    from humanoid.study.commands import resolve
    from humanoid.study.figures import result_table

    for name, study in (("study-push", "push_standing"), ("study-walk", "walk_speed")):
        block = README.split(f"<!-- {name}: begin -->\n", 1)[1].split(f"<!-- {name}: end -->")[0]
        written = (ROOT / "docs" / "studies" / f"{study}.md").read_text()
        assert block == written, f"README {name} differs from docs/studies/{study}.md"
        assert written.startswith(f"`humanoid sweep {study}`: ")
        assert "UTC" in written and "| body.height |" in written
        assert f"docs/studies/{study}.png" in README
        assert (ROOT / "docs" / "studies" / f"{study}.png").stat().st_size > 10_000
        rows = read_table(ROOT / "docs" / "studies" / f"{study}.parquet")
        spec = load_study(resolve(study))
        assert len(rows) == len(spec.runs())
        assert result_table(rows, spec.figure) in written


def test_the_walk_tables_are_the_measured_ones():
    """The README's tables of the person's walks are what `make walk-tables` measured
    (scripts/walk_tables.py writes docs/walks/NAME.md; scripts/readme_tables.py pastes them)."""
    for name in ("cycles", "straight", "speeds", "predictive", "standing", "circle", "sizes"):
        block = README.split(f"<!-- walk-{name}: begin -->\n", 1)[1].split(
            f"<!-- walk-{name}: end -->")[0]  # fmt: skip
        written = (ROOT / "docs" / "walks" / f"{name}.md").read_text()
        assert block == written, f"README walk-{name} differs from docs/walks/{name}.md"
        assert written.startswith("| ") and written.count("\n") >= 3
