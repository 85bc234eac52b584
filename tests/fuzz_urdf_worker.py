"""Child process of the URDF fuzz (tests/test_fuzz.py): loads hypothesis-mutated URDFs.

A crash of the interpreter (Pinocchio's parser on a cycle once segfaulted) must not take the
test run with it, so the loading happens here. Before each load the case is written to
``<out>.case``; each outcome is appended to ``<out>`` as one JSON line. Usage:
``python fuzz_urdf_worker.py N OUT``.
"""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

import numpy as np
from fuzz_tools import seeded
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import humanoid as hm
from humanoid.data import body_path

BASE = body_path("adult_male").read_text()
ATTRIBUTE = re.compile(r'(\w+)="([^"]*)"')
SITES = [m.span(2) for m in ATTRIBUTE.finditer(BASE)]
ELEMENTS = [
    m.span()
    for m in re.finditer(
        r"<(joint|link|inertial|origin|mass|inertia|child|"
        r"parent|limit|axis|collision|visual)\b[^>]*/?>",
        BASE,
    )
]
TOKENS = [
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "1e400",
    "1,2,3",
    "0 0",
    "0 0 0 0",
    "",
    "x",
    "1e308",
    "pelvis",
    "left_foot",
    "continuous",
    "planar",
    "floating",
    "fixed",
    "prismatic",
    "0 0 nan",
    "-0.0",
    "  1  2  3 ",
    "1e-300",
]

mutation = st.one_of(
    st.tuples(
        st.just("attribute"),
        st.integers(0, len(SITES) - 1),
        st.one_of(st.sampled_from(TOKENS), st.text(max_size=8)),
    ),
    st.tuples(st.just("delete"), st.integers(0, len(ELEMENTS) - 1), st.none()),
    st.tuples(st.just("duplicate"), st.integers(0, len(ELEMENTS) - 1), st.none()),
    st.tuples(st.just("truncate"), st.integers(0, len(BASE)), st.none()),
)


def mutate(text: str, edits) -> str:
    """Apply the edits from the end of the file backwards (spans stay valid)."""
    spans = []
    for kind, i, value in edits:
        if kind == "attribute":
            a, b = SITES[i]
            spans.append((a, b, value))
        elif kind == "delete":
            a, b = ELEMENTS[i]
            spans.append((a, b, ""))
        elif kind == "duplicate":
            a, b = ELEMENTS[i]
            spans.append((b, b, BASE[a:b]))
    for a, b, value in sorted(spans, key=lambda s: -s[0]):
        text = text[:a] + value + text[b:]
    for kind, i, _ in edits:
        if kind == "truncate":
            text = text[:i]
    return text


def finite(h) -> bool:
    q = h.standing_configuration()
    M = hm.mass_matrix(h, q)
    return bool(np.all(np.isfinite(q)) and np.all(np.isfinite(M)) and math.isfinite(h.mass))


def main() -> None:
    n, out = int(sys.argv[1]), Path(sys.argv[2])
    case = out.with_suffix(".case")

    @settings(
        max_examples=n,
        derandomize=True,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(
        edits=st.lists(mutation, min_size=1, max_size=3),
        mode=st.sampled_from(["euler", "quaternion"]),
    )
    def one(edits, mode):
        text = mutate(BASE, edits)
        case.write_text(f"{mode}\n{text}")
        try:
            h = hm.load(text, ball_joints=mode, massless="merge")
            result = "loaded" if finite(h) else "non-finite"
        except hm.HumanoidError as exc:
            result = f"typed {type(exc).__name__}"
        except Exception as exc:  # noqa: BLE001 - what the fuzz looks for
            result = f"untyped {type(exc).__name__}: {exc}"
        with out.open("a") as fh:
            fh.write(json.dumps({"edits": repr(edits), "mode": mode, "result": result}) + "\n")

    seeded(one)()  # (not a decorator: derandomize seeds from the source, decorators too)


if __name__ == "__main__":
    main()
