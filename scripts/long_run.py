#!/usr/bin/env python3
"""Ten simulated minutes of welded standing at 1 kHz, recorded at 100 Hz: memory and speed.

Checks the run-loop claims of the simulator: records are preallocated (memory is fixed by the
duration), and a run does not slow down as it goes (the wall time of each simulated minute is
printed). Writes results/long_run/summary.txt and the trajectory.

Usage: python scripts/long_run.py [--minutes 10] [--out results/long_run]
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import numpy as np

from humanoid.scene import Scene
from humanoid.simulation import Simulation, scene_schedule

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--integrator", default="rk4")
    parser.add_argument("--out", default=str(ROOT / "results" / "long_run"))
    args = parser.parse_args()
    scene = Scene.load("standing").replace(
        duration=60.0 * args.minutes, dt=1e-3, record_rate=100.0, integrator=args.integrator
    )
    sim = Simulation(scene)
    lap_times = []
    state = {"last": time.perf_counter(), "next": 60.0}

    def timed(sim, k, t, q, v, last):  # wall time of every simulated minute
        if t >= state["next"] - 1e-9:
            now = time.perf_counter()
            lap_times.append(now - state["last"])
            print(f"minute {len(lap_times):3d}: {lap_times[-1]:7.2f} s wall", flush=True)
            state["last"], state["next"] = now, state["next"] + 60.0
        return scene_schedule(sim, k, t, q, v, last)

    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    traj = sim.run(schedule=timed)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # peak, before saving
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    traj.save(out / "standing_long.npz")
    laps = np.array(lap_times)
    arrays = [traj.t, traj.q, traj.v, traj.tau, traj.energy, traj.residual, *traj.forces.values()]
    nbytes = sum(a.nbytes for a in arrays)
    lines = [
        f"status             {traj.status} {traj.metadata['message']}",
        f"simulated          {traj.t[-1]:.1f} s, {traj.metadata['steps']} steps, "
        f"{len(traj.t)} records",
        f"wall time          {traj.metadata['wall_time']:.1f} s",
        f"trajectory arrays  {nbytes / 1e6:.1f} MB",
        f"process peak RSS   {rss:.0f} MB after the run, {rss_before:.0f} MB before it: "
        f"the run added {rss - rss_before:.0f} MB",
        f"minute wall times  first {laps[0]:.2f} s, last {laps[-1]:.2f} s, "
        f"ratio last/first {laps[-1] / laps[0]:.2f}"
        if len(laps)
        else "minute wall times  -",
        f"max residual       {traj.metadata['max_residual']:.2e}",
        f"energy drift       {traj.energy[-1] - traj.energy[0]:+.3e} J",
    ]
    text = "\n".join(lines)
    (out / "summary.txt").write_text(text + "\n")
    print(text)
    print(f"wrote {out / 'summary.txt'}")


if __name__ == "__main__":
    main()
