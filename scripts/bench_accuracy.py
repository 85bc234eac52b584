#!/usr/bin/env python3
"""Work-precision benchmark: error against a tight reference vs wall time, per method.

Same as `humanoid bench accuracy`. Writes results/bench/accuracy.csv, convergence.csv and
accuracy_<scene>.png, and with MuJoCo installed peers.csv and peers.png.
Usage: python scripts/bench_accuracy.py [--quick] [--out results/bench]
"""

from __future__ import annotations

import argparse

from humanoid.bench.accuracy import run_accuracy_benchmark


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter scenes, fewer settings")
    parser.add_argument("--out", default="results/bench")
    args = parser.parse_args()
    run_accuracy_benchmark(quick=args.quick, out=args.out)


if __name__ == "__main__":
    main()
