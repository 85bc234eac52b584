"""``humanoid bench motion``: inverse dynamics and inverse kinematics against OpenSim 4.

One motion (the male body's walk, 2 steps at 0.8 m/s, recorded at 100 Hz, filtered at 6 Hz)
and its ground forces go through the toolkit's inverse dynamics and OpenSim's
InverseDynamicsTool on the same body (:mod:`humanoid.motion.opensim_peer`); the walk's 64
default markers through the toolkit's inverse kinematics and OpenSim's InverseKinematicsTool.
Times are the best of several rounds in the same run (the machine is shared and noisy; OpenSim's
exclude building its model and writing its input files, ours include everything from the
arrays): the ratios are what to read. Needs ``opensim`` (``pip install opensim``).
"""

from __future__ import annotations

import csv
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from ..errors import require


def run_motion_benchmark(quick: bool = False, out: str | Path = "results/bench") -> int:
    """Time ID and IK, ours against OpenSim's; print a table and write ``motion.csv``."""
    require("opensim", "humanoid bench motion")

    from ..linalg import one_thread
    from ..motion.ik import RangeLimitWarning, inverse_kinematics
    from ..motion.inverse_dynamics import derivatives, inverse_dynamics
    from ..motion.loads import Load
    from ..motion.markers import MarkerTrajectories, default_markers, marker_positions
    from ..motion.opensim_peer import run_opensim_id, run_opensim_ik
    from ..walking.gait import walk_on_ground
    from .common import load_male

    rounds = 2 if quick else 5
    h = load_male()
    tr = walk_on_ground(h, speed=0.8, steps=2).trajectory
    t, q, _, _ = derivatives(h.model, tr.t, tr.q, cutoff=6.0)
    loads = [Load.from_wrench(s, tr.t, tr.forces[f"ground_{s}"]) for s in ("left", "right")]
    markers = default_markers(h)
    seen = MarkerTrajectories(t, list(markers), marker_positions(h, q, markers))
    n = len(t)
    times = {k: np.inf for k in ("id ours", "id opensim", "ik ours", "ik opensim")}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(rounds):
            with one_thread():  # (ours on one thread, as the machine line says)
                start = time.perf_counter()
                inverse_dynamics(h, t, q, loads, cutoff=None)
                times["id ours"] = min(times["id ours"], time.perf_counter() - start)
            _, el = run_opensim_id(h, t, q, loads, Path(tmp) / f"id{k}")
            times["id opensim"] = min(times["id opensim"], el)
            with one_thread(), warnings.catch_warnings():
                warnings.simplefilter("ignore", RangeLimitWarning)  # (the straight knees)
                start = time.perf_counter()
                inverse_kinematics(h, seen, markers)
                times["ik ours"] = min(times["ik ours"], time.perf_counter() - start)
            _, el = run_opensim_ik(h, seen, markers, Path(tmp) / f"ik{k}")
            times["ik opensim"] = min(times["ik opensim"], el)
    print(f"{n} frames (the walk at 100 Hz), {len(markers)} markers; best of {rounds} rounds")
    print(f"{'':22s} {'ours':>12s} {'OpenSim 4':>12s} {'OpenSim / ours':>15s}   [ms per frame]")
    rows = []
    for what in ("id", "ik"):
        a, b = times[f"{what} ours"] / n * 1e3, times[f"{what} opensim"] / n * 1e3
        name = "inverse dynamics" if what == "id" else "inverse kinematics"
        print(f"{name:22s} {a:12.3f} {b:12.3f} {b / a:15.1f}")
        rows.append({"task": name, "frames": n, "ours_ms_per_frame": a,
                     "opensim_ms_per_frame": b, "ratio": b / a})  # fmt: skip
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "motion.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {folder / 'motion.csv'}")
    return 0
