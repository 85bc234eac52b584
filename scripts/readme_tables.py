#!/usr/bin/env python3
"""Put the speed tables that ``humanoid bench step -o docs/bench`` and ``humanoid bench walk -o
docs/bench`` wrote (docs/bench/speed.md, docs/bench/walk.md) into the README, between its
``<!-- speed: begin -->`` / ``<!-- speed: end -->`` and ``<!-- walk-speed: begin -->`` /
``<!-- walk-speed: end -->`` markers.

``make bench`` runs all three. tests/test_readme.py checks that the README carries the files'
text and that the tables' columns are the benchmarks' CSV columns.
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BLOCKS = {"speed": "speed.md", "walk-speed": "walk.md"}


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
        text = paste(text, name, (ROOT / "docs" / "bench" / file).read_text())
    readme.write_text(text)
    print(f"updated {readme} from docs/bench/{', docs/bench/'.join(BLOCKS.values())}")


if __name__ == "__main__":
    main()
