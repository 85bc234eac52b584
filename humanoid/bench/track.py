"""``humanoid bench track``: what tracking a recorded walk costs against real time.

Two walks are followed by :func:`~humanoid.motion.tracking.track` as ``humanoid track`` follows
them, at its default step (:data:`~humanoid.motion.tracking.DT`) and at 1 ms:

- **subject01**: OpenSim's treadmill walk shipped with the package (60 Hz markers), fitted by
  inverse kinematics on the body scaled to its static trial, clamped into the joint ranges,
  its pelvis residuals reduced on loads estimated on its fitted floor, followed in the belt's
  frame (the pipeline of ``humanoid track --reduce``);
- **male walk**: the male body's own walk (2 steps at 0.8 m/s on the rigid ground) at 100 Hz,
  the clean case.

Only the run is timed (the reference's preparation is not): wall time, the real-time factor
(simulated over wall seconds), and its parts (the controller's update, the plant's contact
step, the rest of the loop: the integrator, the fall monitor, the records), best of the
rounds; with whether it completed and how far it stayed from its reference.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from .common import Clock, load_male, write_table

__all__ = ["TRACK_COLUMNS", "run_track_benchmark"]

# track.csv's columns, in the order of the docs' table
TRACK_COLUMNS = ["walk", "dt", "simulated", "wall", "real_time_factor", "controller", "plant",
                 "other", "completed", "joint_rms_deg", "root_max_mm"]  # fmt: skip


def _subject01():
    """(body, time, q, floor) of the shipped subject01 walk, prepared as ``humanoid track
    --reduce`` prepares it."""
    from ..data import TRIALS
    from ..model import load
    from ..motion.floor import fit_floor
    from ..motion.ik import inverse_kinematics
    from ..motion.inverse_dynamics import derivatives, estimate_loads
    from ..motion.markers import read_trc
    from ..motion.reduce import reduce_residuals
    from ..motion.scale import scale_body
    from ..motion.tracking import inside_ranges

    with warnings.catch_warnings():  # (what the trial's fit says is the test suite's to read)
        warnings.simplefilter("ignore")
        scaled = scale_body(load("adult_male"), read_trc(TRIALS / "subject01_static.trc"),
                            None, 72.6)  # fmt: skip
        fit = inverse_kinematics(scaled.body, read_trc(TRIALS / "subject01_walk1.trc"),
                                 scaled.marker_set)  # fmt: skip
        h = scaled.body
        q, _ = inside_ranges(h, fit.q)
        floor = fit_floor(h, fit.time, q)
        loads = estimate_loads(h, *derivatives(h.model, fit.time, q), floor=floor)
        red = reduce_residuals(h, fit.time, q, loads)
    return h, red.time, red.q, floor


def _male_walk():
    """(body, time, q, None): the male body's 2-step walk at 100 Hz."""
    from ..walking.gait import walk_on_ground

    walk = walk_on_ground(load_male(), speed=0.8, steps=2, record_rate=100.0)
    return walk.body, walk.trajectory.t, walk.trajectory.q, None


WALKS = {"subject01": _subject01, "male walk": _male_walk}


def _timed_track(h, time, q, floor, dt: float) -> dict:
    """One tracked run with its parts timed."""
    from ..constraints.ground import ContactSolver
    from ..motion.tracking import MotionTracker, track

    clock = Clock()
    originals = {(MotionTracker, "update"): MotionTracker.update,
                 (ContactSolver, "step"): ContactSolver.step}  # fmt: skip
    try:
        clock.wrap(MotionTracker, "update", "controller")
        clock.wrap(ContactSolver, "step", "plant")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = track(h, time, q, floor=floor, dt=dt)
    finally:
        for (owner, name), fn in originals.items():
            setattr(owner, name, fn)
    err = res.joint_error
    simulated = float(res.trajectory.t[-1] - res.trajectory.t[0])
    wall = res.wall_time
    return {
        "dt": f"{dt * 1e3:g} ms", "simulated": simulated, "wall": wall,
        "real_time_factor": simulated / wall, "controller": clock.total.get("controller", 0.0),
        "plant": clock.total.get("plant", 0.0), "completed": res.completed,
        "joint_rms_deg": float(np.degrees(np.sqrt(np.mean(err[:, 6:] ** 2)))),
        "root_max_mm": float(np.abs(err[:, :3]).max() * 1e3),
    }  # fmt: skip


def run_track_benchmark(quick: bool = False, out: str | Path = "results/bench",
                        walks: tuple[str, ...] = tuple(WALKS)) -> int:  # fmt: skip
    """Track each walk at the default step and at 1 ms; print a table and write ``track.csv``
    and ``track.md``."""
    from ..motion.tracking import DT
    from ..provenance import machine

    rounds = 1 if quick else 3
    rows = []
    for name in walks:
        h, time, q, floor = WALKS[name]()
        for dt in dict.fromkeys((DT, 1e-3)):
            runs = [_timed_track(h, time, q, floor, dt) for _ in range(rounds)]
            row = {"walk": name, **min(runs, key=lambda r: r["wall"])}
            row["other"] = row["wall"] - row["controller"] - row["plant"]
            rows.append(row)
            print(f"{name}, step {row['dt']}: {row['simulated']:.2f} s tracked in "
                  f"{row['wall']:.2f} s ({row['real_time_factor']:.2f}x real time); completed: "
                  f"{row['completed']}, joints {row['joint_rms_deg']:.2f} deg RMS off")  # fmt: skip
    write_table(out, "track", rows, TRACK_COLUMNS, _markdown(rows, machine(), rounds))
    return 0


def _markdown(rows, where: str, rounds: int) -> str:
    lines = [
        f"Measured by `humanoid bench track` on {where}; best of {rounds} "
        f"round{'s' if rounds > 1 else ''}; seconds of wall time for the whole run.",
        "",
        "| walk | step | simulated | wall | real time | controller | plant | other | "
        "completed | joints RMS [deg] | root max [mm] |",
        "|---" * 11 + "|",
    ]
    for r in rows:
        cells = [r["walk"], r["dt"], f"{r['simulated']:.2f}", f"{r['wall']:.2f}",
                 f"{r['real_time_factor']:.2f}x", f"{r['controller']:.2f}", f"{r['plant']:.2f}",
                 f"{r['other']:.2f}", "yes" if r["completed"] else "no",
                 f"{r['joint_rms_deg']:.2f}", f"{r['root_max_mm']:.1f}"]  # fmt: skip
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
