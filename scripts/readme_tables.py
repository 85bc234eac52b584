#!/usr/bin/env python3
"""Put the speed tables that ``humanoid bench step -o docs/bench`` wrote (docs/bench/speed.md)
into the README, between its ``<!-- speed: begin -->`` and ``<!-- speed: end -->`` markers.

``make bench`` runs both. tests/test_readme.py checks that the README carries the file's text.
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BEGIN, END = "<!-- speed: begin -->", "<!-- speed: end -->"


def main() -> None:
    readme = ROOT / "README.md"
    text = readme.read_text()
    tables = (ROOT / "docs" / "bench" / "speed.md").read_text()
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    readme.write_text(f"{head}{BEGIN}\n{tables}{END}{tail}")
    print(f"updated {readme} from docs/bench/speed.md")


if __name__ == "__main__":
    main()
