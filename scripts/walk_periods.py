"""Which control periods the welded walk (``humanoid walk --gait welded``) passes its checks at:
the 10-step walk of each body with its QP every 8 to 16 ms (the contact forces held in
between), and which checks fail. docs/walking.md and ``humanoid.walking.run.CONTROL_PERIOD``
quote it.

    python scripts/walk_periods.py [--steps 10] [--periods 8 10 12 14 16]
"""

from __future__ import annotations

import argparse
import time

import humanoid as hm
from humanoid.walking.plan import GaitParameters
from humanoid.walking.run import walk

# the bodies: the package's male and female (feet with toes), the benchmarks' male with
# one-piece feet (``humanoid bench walk``), example-robot-data's human
BODIES = {
    "male": lambda: hm.load("adult_male"),
    "female": lambda: hm.load("adult_female"),
    "male, one-piece feet": lambda: hm.load(
        hm.build_urdf(hm.BodyParameters(1.75, 75.0, "male", toes=False))
    ),
    "human (erd)": lambda: hm.load("human"),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--periods", type=float, nargs="+", default=[8, 10, 12, 14, 16],
                        help="control periods [ms]")  # fmt: skip
    args = parser.parse_args()
    print("| body | period | checks pass | failed | real time |")
    print("|---|---|---|---|---|")
    for name, load in BODIES.items():
        h = load()
        for period in args.periods:
            start = time.perf_counter()
            r = walk(h, GaitParameters(steps=args.steps), quiet=True, control_dt=period * 1e-3)
            wall = time.perf_counter() - start
            failed = ", ".join(k for k, c in r.checks.items() if not c["ok"]) or "-"
            print(f"| {name} | {period:g} ms | {'yes' if r.ok else 'no'} | {failed} | "
                  f"{r.summary['simulated'] / wall:.1f}x |", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
