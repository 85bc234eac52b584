"""The README and the docs' guides are part of the product: their snippets run, their facts
match the project, and the guides build as a site with warnings as errors."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from conftest import clean_library_path

ROOT = Path(__file__).resolve().parent.parent
RUNNER = ROOT / "scripts" / "readme_snippets.py"
README = (ROOT / "README.md").read_text(encoding="utf-8")
DOCS = ROOT / "docs"
GUIDES = sorted(DOCS.glob("*.md"))  # the tables' files under docs/bench, studies, walks aside
WITH_CODE = [p for p in GUIDES if "```python\n" in p.read_text(encoding="utf-8")]


def _guide(name: str) -> str:
    return (DOCS / name).read_text(encoding="utf-8")


def _run(*files: Path):
    # without OpenSim's LD_LIBRARY_PATH (set when another test imported it): its bundled casadi
    # would break the optimal-control snippets
    return subprocess.run([sys.executable, str(RUNNER), *map(str, files)], capture_output=True,
                          text=True, timeout=900, env=clean_library_path())  # fmt: skip


def test_the_readme_python_snippets_run_as_written():
    done = _run(ROOT / "README.md")
    assert done.returncode == 0, done.stderr
    n = len(re.findall(r"```python\n", README))
    assert n >= 2
    assert f"{n} snippets of README.md ran" in done.stdout


@pytest.mark.parametrize("guide", WITH_CODE, ids=[p.name for p in WITH_CODE])
def test_the_guides_python_snippets_run_as_written(guide):
    """Every ```python block of docs/*.md runs, each file's in order in a namespace of its own."""
    done = _run(guide)
    assert done.returncode == 0, done.stderr
    n = len(re.findall(r"```python\n", guide.read_text(encoding="utf-8")))
    assert f"{n} snippets of docs/{guide.name} ran" in done.stdout


def test_the_guides_with_code_are_the_ones_expected():
    # a guide whose snippets vanished would silently run nothing
    names = {p.name for p in WITH_CODE}
    assert {"loading.md", "dynamics.md", "simulation.md", "walking.md"} <= names, names


def test_the_readme_is_short_and_opens_with_the_two_commands():
    lines = README.splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines (at most 250: move text to docs/)"
    assert lines[0] == "# humanoid"
    assert lines[2] == "```bash"
    assert lines[3].startswith("make demo ") and "#" in lines[3]
    assert lines[4].startswith("make test ") and "#" in lines[4]
    assert lines[5] == "```"


def test_the_readme_links_every_guide_and_every_guide_is_in_the_site():
    index = _guide("index.md")
    toctree = index.split("```{toctree}", 1)[1].split("```", 1)[0]
    listed = {x.strip() for x in toctree.splitlines() if x.strip() and not x.startswith(":")}
    for page in GUIDES:
        if page.name != "index.md":
            assert f"(docs/{page.name})" in README, f"README.md does not link docs/{page.name}"
            assert page.stem in listed, f"docs/index.md's toctree misses {page.stem}"
    for name in listed:
        assert (DOCS / f"{name}.md").is_file(), name


@pytest.mark.skipif(
    importlib.util.find_spec("sphinx") is None or importlib.util.find_spec("myst_parser") is None,
    reason="sphinx and myst-parser are not installed (the docs and test extras have them)",
)
def test_the_docs_build_with_warnings_as_errors(tmp_path):
    """`make docs`: the guides and the API reference from the docstrings, warnings as errors."""
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b",
                           "html", "-d", str(tmp_path / "doctrees"), str(DOCS),
                           str(tmp_path / "html")], capture_output=True, text=True,
                          timeout=900, env=clean_library_path())  # fmt: skip
    assert done.returncode == 0, done.stderr[-5000:]
    for page in GUIDES:
        assert (tmp_path / "html" / f"{page.stem}.html").is_file(), page.name
    api = (tmp_path / "html" / "api.html").read_text(encoding="utf-8")
    for name in (
        "humanoid.model.load",
        "humanoid.simulation.simulate",
        "humanoid.motion.ik.inverse_kinematics",
        "humanoid.walking.person.walk_cycle",
    ):
        assert f'id="{name}"' in api, name


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
    for name, text in (("README.md", README), ("docs/install.md", _guide("install.md"))):
        stated = set(re.findall(r"Python >= (\d+\.\d+)", text))
        assert stated == {need}, (name, stated)


def test_the_readme_names_no_file_outside_the_repo():
    for name, text in [("README.md", README)] + [(p.name, p.read_text()) for p in GUIDES]:
        assert "shared/" not in text, name
        for path in re.findall(r"`((?:docs|humanoid|scripts|tests)/[\w./-]+)`", text):
            assert (ROOT / path).exists(), (name, path)
        # the README's links and the guides' links and images within the repo resolve
        base = ROOT if name == "README.md" else DOCS
        for link in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
            if "://" not in link:
                assert (base / link).exists(), (name, link)


def test_the_speed_tables_are_the_benchmark_output():
    """The speed tables of docs/benchmarks.md are the text `humanoid bench step|walk -o
    docs/bench` wrote (`make bench` pastes it), with the machine and the date they were
    measured on; their columns are the benchmarks' CSV columns, and their numbers those of
    the CSV files."""
    import csv
    import re

    from humanoid.bench.step import STEP_COLUMNS
    from humanoid.bench.walk import WALK_COLUMNS

    for name, file, command in (("speed", "speed.md", "step"), ("walk-speed", "walk.md", "walk"),
                                ("person-speed", "person.md", "walk"),
                                ("track-speed", "track.md", "track")):  # fmt: skip
        guide = _guide("benchmarks.md")
        block = guide.split(f"<!-- {name}: begin -->\n", 1)[1].split(f"<!-- {name}: end -->")[0]
        written = (ROOT / "docs" / "bench" / file).read_text()
        assert block == written, f"docs/benchmarks.md {name} differs from docs/bench/{file}"
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
    # the walks' tables: a row per control period with their CSV's numbers
    from humanoid.bench.walk import PERSON_COLUMNS

    for name, columns, rate, second, done in (
        ("walk", WALK_COLUMNS, "{:.1f}x", "ratio", "checks_passed"),
        ("person", PERSON_COLUMNS, "{:.2f}x", "solves", "completed"),
    ):
        table = (ROOT / "docs" / "bench" / f"{name}.md").read_text()
        with open(ROOT / "docs" / "bench" / f"{name}.csv") as fh:
            rows = list(csv.DictReader(fh))
        assert list(rows[0]) == columns
        for row in rows:
            line = next(x for x in table.splitlines() if x.startswith(f"| {row['control']} |"))
            shown = [c.strip() for c in line.strip("|").split("|")]
            assert shown[1] == rate.format(float(row["real_time_factor"]))
            assert shown[2] == f"{float(row[second]):.{1 if name == 'walk' else 0}f}"
            assert shown[3] == f"{float(row['wall']) * 1e3:.1f}"
            assert shown[-1] == ("yes" if row[done] == "True" else "no")


def test_the_study_results_are_the_sweeps_output():
    """The study results of docs/studies.md are the text `humanoid sweep
    push_standing|walk_speed` wrote (`make studies` copies it to docs/studies/ and pastes
    it), with the machine and the date;
    their figures are there; their tables are the reductions of the Parquet tables copied
    beside them, by the study files' figure sections."""
    from humanoid.study import load_study, read_table
    from humanoid.study.commands import resolve
    from humanoid.study.figures import result_table

    for name, study in (("study-push", "push_standing"), ("study-walk", "walk_speed")):
        guide = _guide("studies.md")
        block = guide.split(f"<!-- {name}: begin -->\n", 1)[1].split(f"<!-- {name}: end -->")[0]
        written = (ROOT / "docs" / "studies" / f"{study}.md").read_text()
        assert block == written, f"docs/studies.md {name} differs from docs/studies/{study}.md"
        assert written.startswith(f"`humanoid sweep {study}`: ")
        assert "UTC" in written and "| body.height |" in written
        assert f"](studies/{study}.png)" in guide
        assert (ROOT / "docs" / "studies" / f"{study}.png").stat().st_size > 10_000
        rows = read_table(ROOT / "docs" / "studies" / f"{study}.parquet")
        spec = load_study(resolve(study))
        assert len(rows) == len(spec.runs())
        assert result_table(rows, spec.figure) in written


def test_the_walk_tables_are_the_measured_ones():
    """The tables of the person's walks in docs/walking.md are what `make walk-tables`
    measured (scripts/walk_tables.py writes docs/walks/NAME.md; scripts/readme_tables.py
    pastes them)."""
    guide = _guide("walking.md")
    for name in ("cycles", "straight", "speeds", "predictive", "standing", "circle", "sizes"):
        block = guide.split(f"<!-- walk-{name}: begin -->\n", 1)[1].split(
            f"<!-- walk-{name}: end -->")[0]  # fmt: skip
        written = (ROOT / "docs" / "walks" / f"{name}.md").read_text()
        assert block == written, f"docs/walking.md walk-{name} differs from docs/walks/{name}.md"
        assert written.startswith("| ") and written.count("\n") >= 3
