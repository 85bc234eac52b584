"""Fit the walking cycles shipped as package data (humanoid/data/cycles): both bodies with
their toes locked, at their free speed and at 0.8 m/s (what `humanoid walk --gait human`, the
tests and the studies fit), and example-robot-data's g1 at 0.6 m/s and human at 0.8 m/s (the
tests' walks of other robots; a newer example-robot-data changes their digests, and they are
then fitted as before). About 20 s each. Run after a change to the fitting code (the test
suite says when: tests/test_cache.py)."""

from __future__ import annotations

import humanoid as hm
from humanoid.data import BODIES
from humanoid.model import lock_foot_hinges
from humanoid.walking.reference import CYCLES, FRAMES, cycle_file, fit_cycle, write_cycle

ROBOTS = (("g1", 0.6), ("human", 0.8))


def main() -> None:
    CYCLES.mkdir(parents=True, exist_ok=True)
    for old in CYCLES.glob("*.npz"):
        old.unlink()
    for body in ("adult_male", "adult_female"):
        for h in (
            lock_foot_hinges(hm.load(BODIES / f"{body}.urdf")),
            hm.load(BODIES / f"{body}.urdf"),
        ):
            for speed in (None, 0.8):
                cycle = fit_cycle(h, speed, cache=False)
                name = cycle_file(h, cycle.gait["speed"], None, FRAMES)
                write_cycle(cycle, CYCLES / name)
                print(f"{body} {h.model.nq} {cycle.gait['speed']:.3f} m/s -> {name}")
    for robot, speed in ROBOTS:
        h = hm.load(robot)
        cycle = fit_cycle(h, speed, cache=False)
        name = cycle_file(h, cycle.gait["speed"], None, FRAMES)
        write_cycle(cycle, CYCLES / name)
        print(f"{robot} {h.model.nq} {speed:.3f} m/s -> {name}")


if __name__ == "__main__":
    main()
