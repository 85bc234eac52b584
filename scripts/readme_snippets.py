#!/usr/bin/env python3
"""Run the Python snippets of the README and of the docs' guides as written: each file's in
order, in one namespace of its own, in a scratch folder of its own.

Usage: python scripts/readme_snippets.py [FILE.md ...]   (default: README.md)

Exits non-zero (with the file, the snippet's number and the traceback) if one fails. The test
suite runs it on the repo's README.md and docs/*.md; CI runs it again with the installed
wheel, from outside the repo.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def snippets(path: Path) -> list[str]:
    """The ```python blocks of a Markdown file."""
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), re.S)


def label(path: Path) -> str:
    """The file as the messages name it: its path in the repo, else its name."""
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return path.name


def run(path: Path) -> bool:
    """Run the file's snippets; False (the traceback printed) at the first that fails."""
    blocks, name = snippets(path), label(path)
    namespace: dict = {"__name__": "__readme__"}
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # snippets that write files write them here
        try:
            for i, code in enumerate(blocks):
                try:
                    exec(compile(code, f"{name} snippet {i + 1}", "exec"), namespace)
                except Exception:
                    traceback.print_exc()
                    print(f"{name} snippet {i + 1} of {len(blocks)} failed", file=sys.stderr)
                    return False
        finally:
            os.chdir(here)
    print(f"{len(blocks)} snippets of {name} ran", flush=True)
    return True


def main() -> int:
    paths = [Path(a).resolve() for a in sys.argv[1:]] or [ROOT / "README.md"]
    with_code = [p for p in paths if snippets(p)]
    for path in paths:
        if path not in with_code:
            print(f"no python snippets in {label(path)}", file=sys.stderr)
    if not with_code:
        return 1
    ok = [run(path) for path in with_code]
    return 0 if all(ok) else 1


if __name__ == "__main__":
    sys.exit(main())
