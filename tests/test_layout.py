"""The package's shape: no import cycles; benchmarks live apart from the core."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "humanoid"


def _imports() -> dict[str, set[str]]:
    """Module -> the package modules it imports (relative imports, at any depth)."""
    mods = {}
    for p in PACKAGE.rglob("*.py"):
        parts = p.relative_to(PACKAGE.parent).with_suffix("").parts
        mods[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    graph = {m: set() for m in mods}
    for m, p in mods.items():
        pkg = m if p.name == "__init__.py" else m.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
                for c in (target, *(f"{target}.{a.name}" for a in node.names)):
                    if c in mods and c != m and not m.startswith(c + "."):
                        graph[m].add(c)
    return graph


def test_no_import_cycles():
    graph = _imports()
    assert "humanoid.scene" in graph["humanoid.simulate"]  # the walk sees the imports

    def reaches(start, goal, seen):
        for n in graph[start]:
            if n == goal or (n not in seen and (seen.add(n) or reaches(n, goal, seen))):
                return True
        return False

    cycles = sorted(m for m in graph if reaches(m, m, set()))
    assert not cycles, f"modules in an import cycle: {cycles}"


def test_the_core_does_not_import_the_benchmarks():
    graph = _imports()
    core = [m for m in graph if not m.startswith("humanoid.bench") and m != "humanoid.cli"]
    for m in core:
        assert not any(n.startswith("humanoid.bench") for n in graph[m]), m
