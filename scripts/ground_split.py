"""Where a ground-contact step's time goes: each shipped fall (drop, collapse, slide; or the
scenes named) run for its first 2 s on one thread, with the step's pieces wrapped in timers:
detection, the contacts' Jacobian, the joint-range rows, the compiled solve (with its Delassus
matrix) and Pinocchio's ADMM (the steps handed to it), the whole contact step and the whole
step (``advance``: the contact step plus the mass matrix with the
implicit gains and the free velocity). Microseconds per step, means over the run; the wrappers
add about a microsecond each. docs/benchmarks.md quotes it.

    python scripts/ground_split.py [drop collapse slide]
"""

from __future__ import annotations

import sys

from humanoid.bench.common import MALE, Clock
from humanoid.data import SCENES
from humanoid.linalg import one_thread
from humanoid.scene import Scene
from humanoid.simulation import Simulation


def split(name: str, duration: float = 2.0) -> str:
    scene = Scene.load(SCENES / f"{name}.toml").replace(duration=duration, body=MALE)
    sim = Simulation(scene)
    ground = sim.plant.ground
    assert ground is not None, f"{name} has no ground contact"
    solver = ground.solver
    clock = Clock()
    clock.wrap(solver.ground, "detect", "detection")
    clock.wrap(solver.ground, "jacobian", "jacobian")
    if solver.ranges is not None:
        clock.wrap(solver.ranges, "rows", "range rows")
    clock.wrap(solver, "_kernel_solve", "compiled solve")  # the default solver ("kernel")
    clock.wrap(solver, "_pinocchio_solve", "Pinocchio's ADMM")  # "admm", or handed over
    clock.wrap(solver, "step", "contact step")
    clock.wrap(ground, "advance", "whole step")
    traj = sim.run(quiet=True)
    n = traj.metadata["steps"]
    parts = ", ".join(f"{k} {v / n * 1e6:.0f}" for k, v in clock.total.items())
    return f"{name}: {traj.metadata['wall_time'] / n * 1e6:.0f} us a step in the loop; {parts}"


def main(names: list[str]) -> None:
    with one_thread():
        for name in names or ["drop", "collapse", "slide"]:
            print(split(name))


if __name__ == "__main__":
    main(sys.argv[1:])
