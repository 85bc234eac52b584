#!/usr/bin/env python3
"""Work-precision benchmark: error against a tight reference vs wall time, per method.

Same as `humanoid bench accuracy`. Writes results/bench/accuracy.csv, convergence.csv and
accuracy_<scene>.png, and with MuJoCo installed peers.csv and peers.png.
Usage: python scripts/bench_accuracy.py [--quick] [--falls] [--out results/bench]
(--falls: the falls onto the floor alone, their rows put into the folder's accuracy.csv)
"""

from __future__ import annotations

import argparse

from humanoid.bench.accuracy import run_accuracy_benchmark, run_fall_benchmark


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter scenes, fewer settings")
    parser.add_argument("--falls", action="store_true", help="the falls onto the floor alone")
    parser.add_argument("--out", default="results/bench")
    args = parser.parse_args()
    run = run_fall_benchmark if args.falls else run_accuracy_benchmark
    run(quick=args.quick, out=args.out)


if __name__ == "__main__":
    main()
