#!/usr/bin/env python3
"""The cost of one simulation step per shipped scene, against Pinocchio in the same run.

Same as `humanoid bench step`. Writes results/bench/step.csv.
Usage: python scripts/bench_step.py [--quick] [--out results/bench]
"""

from __future__ import annotations

import argparse

from humanoid.bench.step import run_step_benchmark


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    parser.add_argument("--out", default="results/bench")
    args = parser.parse_args()
    run_step_benchmark(quick=args.quick, out=args.out)


if __name__ == "__main__":
    main()
