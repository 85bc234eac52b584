#!/usr/bin/env python3
"""Put the tables that the benchmarks and the studies wrote into the docs' guides, between
their ``<!-- NAME: begin -->`` / ``<!-- NAME: end -->`` markers: the speed tables of
``humanoid bench step|walk|track -o docs/bench`` (docs/bench/speed.md, walk.md, person.md,
track.md) into
docs/benchmarks.md, the results of ``humanoid sweep push_standing|walk_speed`` (copied to
docs/studies/*.md) into docs/studies.md, and the person's walks' tables of
``scripts/walk_tables.py`` (docs/walks/*.md) into docs/walking.md.

``make bench``, ``make studies`` and ``make walk-tables`` run it. tests/test_readme.py checks
that the guides carry the files' text and that the speed tables' columns are the benchmarks'
CSV columns.
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
WALKS = ("cycles", "straight", "speeds", "predictive", "standing", "circle", "sizes")
# the block's name -> (the guide it is in, the file it holds), under docs/
BLOCKS = {
    "speed": ("benchmarks.md", "bench/speed.md"),
    "walk-speed": ("benchmarks.md", "bench/walk.md"),
    "person-speed": ("benchmarks.md", "bench/person.md"),
    "track-speed": ("benchmarks.md", "bench/track.md"),
    "study-push": ("studies.md", "studies/push_standing.md"),
    "study-walk": ("studies.md", "studies/walk_speed.md"),
    **{f"walk-{name}": ("walking.md", f"walks/{name}.md") for name in WALKS},
}


def paste(text: str, name: str, tables: str) -> str:
    """``text`` with the block ``name`` replaced by ``tables``."""
    begin, end = f"<!-- {name}: begin -->", f"<!-- {name}: end -->"
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{tables}{end}{tail}"


def main() -> None:
    for page in sorted({page for page, _ in BLOCKS.values()}):
        guide = DOCS / page
        text = guide.read_text()
        for name, (where, file) in BLOCKS.items():
            path = DOCS / file
            if where == page and path.is_file() and f"<!-- {name}: begin -->" in text:
                text = paste(text, name, path.read_text())
        guide.write_text(text)
        files = [f"docs/{file}" for where, file in BLOCKS.values() if where == page]
        print(f"updated docs/{page} from {', '.join(files)}")


if __name__ == "__main__":
    main()
