#!/usr/bin/env python3
"""Put the tables that the benchmarks and the studies wrote into the README, between its
``<!-- NAME: begin -->`` / ``<!-- NAME: end -->`` markers: the speed tables of ``humanoid bench
step|walk -o docs/bench`` (docs/bench/speed.md, walk.md) and the results of ``humanoid sweep
push_standing|walk_speed`` (copied to docs/studies/*.md), and the person's walks' tables of
``scripts/walk_tables.py`` (docs/walks/*.md).

``make bench`` and ``make studies`` run it. tests/test_readme.py checks that the README carries
the files' text and that the speed tables' columns are the benchmarks' CSV columns.
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BLOCKS = {
    "speed": "bench/speed.md",
    "walk-speed": "bench/walk.md",
    "study-push": "studies/push_standing.md",
    "study-walk": "studies/walk_speed.md",
    **{
        f"walk-{name}": f"walks/{name}.md"
        for name in ("cycles", "straight", "speeds", "predictive", "standing", "circle", "sizes")
    },
}


def paste(text: str, name: str, tables: str) -> str:
    """``text`` with the block ``name`` replaced by ``tables``."""
    begin, end = f"<!-- {name}: begin -->", f"<!-- {name}: end -->"
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{tables}{end}{tail}"


def main() -> None:
    readme = ROOT / "README.md"
    text = readme.read_text()
    for name, file in BLOCKS.items():
        path = ROOT / "docs" / file
        if path.is_file() and f"<!-- {name}: begin -->" in text:
            text = paste(text, name, path.read_text())
    readme.write_text(text)
    print(f"updated {readme} from docs/{', docs/'.join(BLOCKS.values())}")


if __name__ == "__main__":
    main()
