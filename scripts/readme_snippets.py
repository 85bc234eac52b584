#!/usr/bin/env python3
"""Run the README's Python snippets as written, in order, in one namespace, in a scratch folder.

Usage: python scripts/readme_snippets.py [README.md]

Exits non-zero (with the snippet's number and the traceback) if one fails. The test suite runs
it on the repo; CI runs it again with the installed wheel, from outside the repo.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
import traceback
from pathlib import Path


def snippets(readme: Path) -> list[str]:
    """The ```python blocks of a Markdown file."""
    return re.findall(r"```python\n(.*?)```", readme.read_text(encoding="utf-8"), re.S)


def main() -> int:
    readme = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parent.parent / "README.md")
    blocks = snippets(readme.resolve())
    if not blocks:
        print(f"no python snippets in {readme}", file=sys.stderr)
        return 1
    namespace: dict = {"__name__": "__readme__"}
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # snippets that write files write them here
        for i, code in enumerate(blocks):
            try:
                exec(compile(code, f"README.md snippet {i + 1}", "exec"), namespace)
            except Exception:
                traceback.print_exc()
                print(f"README.md snippet {i + 1} of {len(blocks)} failed", file=sys.stderr)
                return 1
    print(f"{len(blocks)} README snippets ran")
    return 0


if __name__ == "__main__":
    sys.exit(main())
