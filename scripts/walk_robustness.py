"""How often a walk on the ground completes when its start is disturbed: the same walk
(``walk_on_ground``) run from the cycle's start with every velocity moved by ``EPS`` times a
seeded standard normal (seeds 1..N), two at a time; of the walks that complete, their largest
slide of a stance (the gait analysis's). A walk at the edge of falling is chaotic:
round-off alone (another machine's BLAS) changes which of its runs fall, so one run proves
little. docs/walking.md quotes it for example-robot-data's human.

    python scripts/walk_robustness.py [--model human] [--speed V] [--steps 8] [--runs 12]
        [--eps 1e-6] [--gain PLACEMENT_BEHIND]
"""

from __future__ import annotations

import argparse
import math
import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import humanoid as hm
from humanoid.linalg import one_thread
from humanoid.walking import gait
from humanoid.walking.tracking import TrackingGains

RUN = gait.Simulation.run  # the undisturbed run (a worker runs several walks)


def one(args: tuple) -> tuple[int, bool, float, float]:
    seed, model, speed, steps, eps, gain = args
    warnings.simplefilter("ignore")

    def disturbed(self, *a, initial, **k):
        q0, v0 = initial
        v0 = v0 + eps * np.random.default_rng(seed).standard_normal(v0.shape)
        return RUN(self, *a, initial=(q0, v0), **k)

    gait.Simulation.run = disturbed  # this worker process's own copy
    gains = TrackingGains() if gain is None else TrackingGains(placement_behind=gain)
    h = hm.load(model)
    with one_thread():
        w = gait.walk_on_ground(h, speed=speed, steps=steps, gains=gains)
        if not w.completed:
            return seed, False, float(w.record.t[-1]), math.nan
        a = gait.analyse(h, w)
    slide = max(f["slip"] for s in a.feet for f in a.feet[s])
    return seed, True, float(w.record.t[-1]), slide


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--model", default="human")
    p.add_argument(
        "--speed",
        type=float,
        default=None,
        help="[m/s] (default: 0.8 for the human, else the body's free speed)",
    )
    p.add_argument("--steps", type=int, default=8)
    p.add_argument("--runs", type=int, default=12)
    p.add_argument("--eps", type=float, default=1e-6, help="[m/s, rad/s] the disturbance")
    p.add_argument("--gain", type=float, default=None, help="TrackingGains.placement_behind")
    a = p.parse_args()
    if a.speed is None and a.model == "human":
        a.speed = 0.8
    jobs = [(s, a.model, a.speed, a.steps, a.eps, a.gain) for s in range(1, a.runs + 1)]
    with ProcessPoolExecutor(2) as pool:
        results = list(pool.map(one, jobs))
    falls = [f"{t:.2f} s (seed {s})" for s, ok, t, _ in results if not ok]
    slides = [1e3 * x for *_, x in results if math.isfinite(x)]
    speed = "its free speed" if a.speed is None else f"{a.speed} m/s"
    print(f"{a.model} at {speed}, {a.steps} steps, starts {a.eps:g} apart: "
          f"{len(results) - len(falls)} of {len(results)} completed"
          + (f"; fell at {', '.join(falls)}" if falls else "")
          + (f"; largest slide of a stance {min(slides):.2f}-{max(slides):.2f} mm, median "
             f"{np.median(slides):.2f}" if slides else ""))  # fmt: skip


if __name__ == "__main__":
    main()
