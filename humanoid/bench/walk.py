"""``humanoid bench walk``: what a simulated second of walking costs, and where it goes.

The welded walk (``humanoid walk``: the male body, the default gait) is run with its controller
at the default period and at every step (1 ms). Each run's wall time is split by timing the
pieces of the one loop: the controller's QP ticks (assembly: kinematics, tasks, constraints;
the joint ranges' rows; ProxQP's solve), the torques between QP ticks (the held contact
forces, :meth:`~humanoid.walking.controller.WalkingController.held_torques`), the plant's step
(the native constrained dynamics and the integrator), the checks (per tick, and the series
after the run) and the records; "other" is the rest of the loop (the contact schedule, the
divergence guard). The bare plant is the same ticks through ``pin.constraintDynamics`` and
``pin.integrate`` alone on the walk's states (both feet welded, then one), measured in the same
run: the walk's cost is read as a multiple of it.

The person's walk (``humanoid walk``: the male body's optimised cycle on the rigid ground) is
timed at its default QP period and at every step, split into the QP ticks, the held torques
between them, the plant's step (the frictional ground contact; ADMM's share of it apart) and
the gait record.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from .common import Clock, load_male, pinocchio_contacts, write_table

if TYPE_CHECKING:
    from ..walking.gait import GroundWalk
    from ..walking.run import WalkResult

__all__ = ["PERSON_COLUMNS", "WALK_COLUMNS", "run_walk_benchmark"]

# walk.csv's columns, in the order of the README's table: per simulated second [s]
WALK_COLUMNS = ["control", "real_time_factor", "wall", "bare_plant", "ratio", "qp_assembly",
                "joint_ranges", "qp_solve", "held", "plant", "checks", "records", "other",
                "checks_passed"]  # fmt: skip


def _timed_walk(h, gait, control_dt: float) -> tuple[dict, WalkResult, list]:
    """One walk with its pieces timed; returns (seconds by piece, result, states for the bare
    plant: (q, v, welds) samples)."""
    from ..simulation.plant import Plant
    from ..trajectory import Recorder
    from ..walking import run as walk_run

    clock = Clock()
    samples: list[tuple[np.ndarray, np.ndarray, list]] = []
    original = Recorder.add
    record = clock.timed(original, "records")

    def add(rec, sim, t, q, v, step):
        record(rec, sim, t, q, v, step)
        if len(samples) < 400 and rec.n % 5 == 0:
            samples.append((q.copy(), v.copy(), list(sim.active_constraints())))

    prepare = walk_run.prepare

    def prepared(*args, **kwargs):
        setup = prepare(*args, **kwargs)
        ctl = setup.ctl
        clock.wrap(ctl, "update", "qp_tick")
        clock.wrap(ctl.qp, "solve", "qp_solve")
        clock.wrap(ctl.ranges, "rows", "joint_ranges")
        clock.wrap(ctl, "held_torques", "held")
        return setup

    monitor_cls = walk_run.WalkMonitor

    class Monitor(walk_run.WalkMonitor):
        def __init__(self, *args) -> None:
            super().__init__(*args)
            clock.wrap(self, "observe", "checks")
            clock.wrap(self, "series_until", "checks")

    step = Plant.step  # (the plant the walk's run builds with its controller)
    # the run's pieces patched to time them (put back below): mypy forbids assigning to methods
    # and classes
    Recorder.add, walk_run.prepare, walk_run.WalkMonitor = add, prepared, Monitor  # type: ignore[method-assign, misc, assignment]
    Plant.step = clock.timed(step, "plant")  # type: ignore[method-assign]
    try:
        start = time.perf_counter()
        result = walk_run.walk(h, gait, quiet=True, control_dt=control_dt)
        wall = time.perf_counter() - start
    finally:
        Recorder.add, walk_run.prepare, walk_run.WalkMonitor = original, prepare, monitor_cls  # type: ignore[method-assign, misc]
        Plant.step = step  # type: ignore[method-assign]
    seconds = dict(clock.total)
    seconds["wall"] = wall
    return seconds, result, samples


def _bare_plant(model, samples, dt: float, rounds: int) -> float:
    """Mean seconds per tick of pin.constraintDynamics + pin.integrate over the walk's states,
    with its stance welds as Pinocchio's own rigid constraints (best of ``rounds``; a Data is
    initialised per stance, once, as a run does per active set)."""
    cases, datas = [], {}
    anchors = model.createData()  # the welds' anchors, as oMf of their frames
    for q, v, welds in samples:
        for w in welds:
            anchors.oMf[w.frame_id] = w.anchor
        stance = tuple(w.frame_id for w in welds)
        cms, cds = pinocchio_contacts(model, anchors, welds=stance)
        if stance not in datas:
            datas[stance] = model.createData()
            pin.initConstraintDynamics(model, datas[stance], cms, cds)
        cases.append((q, v, cms, cds, datas[stance]))
    prox = pin.ProximalSettings(1e-12, 1e-12, 0.0, 1)
    tau = np.zeros(model.nv)
    best = float("inf")
    for _ in range(rounds):
        start = time.perf_counter()
        for q, v, cms, cds, data in cases:
            a = pin.constraintDynamics(model, data, q, v, tau, cms, cds, prox)
            pin.integrate(model, q, (v + dt * a) * dt)
        best = min(best, (time.perf_counter() - start) / len(cases))
    return best


# person.csv's columns, in the order of the README's table: per simulated second [s] but for
# control (the QP's period), real_time_factor, solves (QP solves per simulated second) and
# completed
PERSON_COLUMNS = ["control", "real_time_factor", "wall", "solves", "qp", "held", "plant",
                  "solve", "record", "other", "completed"]  # fmt: skip


def _timed_person(h, steps: int, control_dt: float) -> tuple[dict, GroundWalk]:
    """The person's walk (``humanoid walk``'s default gait) of ``steps`` heel strikes with its
    pieces timed: the QP ticks, the held torques between them, the plant's step (the ground
    contact: detection, the joint ranges' rows, the contact solve) and the solve in it (the
    compiled ADMM with its Delassus matrix, and the steps it hands to Pinocchio's), the gait
    record (:class:`~humanoid.walking.gait.GaitRecorder`); returns (seconds by piece, the
    walk)."""
    from ..constraints.ground import ContactSolver
    from ..simulation.plant import Plant
    from ..walking.gait import GaitRecorder
    from ..walking.person import CycleTracker, Sampled
    from ..walking.walkers import ground_walker

    clock = Clock()
    _, walk = ground_walker(h, "person", dt=1e-3, mu=0.8, quiet=True, control_dt=control_dt)
    patched = [(CycleTracker, "update", "qp"), (Sampled, "torques", "held"),
               (Plant, "step", "plant"), (GaitRecorder, "observe", "record"),
               (GaitRecorder, "record", "record"),
               (ContactSolver, "_kernel_solve", "solve")]  # fmt: skip
    originals = [(owner, name, getattr(owner, name)) for owner, name, _ in patched]
    for owner, name, label in patched:
        setattr(owner, name, clock.timed(getattr(owner, name), label))
    try:
        start = time.perf_counter()
        result = walk(steps, ())
        wall = time.perf_counter() - start
    finally:
        for owner, name, original in originals:
            setattr(owner, name, original)
    seconds = dict(clock.total)
    seconds["wall"] = wall
    return seconds, result


def _person_rows(h, steps: int) -> list[dict]:
    """The person's walk at its default QP period and at every step."""
    from ..walking.person import CONTROL_PERIOD

    rows = []
    for control in (CONTROL_PERIOD, 1e-3):
        seconds, result = _timed_person(h, steps, control)
        simulated = float(result.record.t[-1] + result.record.dt)
        per = {k: v / simulated for k, v in seconds.items()}
        row = {
            "control": f"{control * 1e3:g} ms",
            "real_time_factor": simulated / seconds["wall"],
            "solves": result.trajectory.metadata["qp_solves"] / simulated,
            "completed": result.completed,
        }
        for k in ("wall", "qp", "held", "plant", "solve", "record"):
            row[k] = per.get(k, 0.0)
        row["other"] = row["wall"] - sum(row[k] for k in ("qp", "held", "plant", "record"))
        rows.append(row)
        print(f"the person's walk, QP every {row['control']}: {simulated:.2f} s walked in "
              f"{seconds['wall']:.2f} s ({row['real_time_factor']:.2f}x real time); completed: "
              f"{result.completed}")  # fmt: skip
    return rows


def _person_markdown(rows, where: str, steps: int) -> str:
    ms = [("wall", "wall"), ("qp", "QP ticks"), ("held", "held torques"), ("plant", "plant"),
          ("solve", "of which the solve"), ("record", "gait record"),
          ("other", "other")]  # fmt: skip
    title = (f"Measured by `humanoid bench walk` on {where}: the male body's person's walk "
             f"(`humanoid walk`), {steps} steps; milliseconds of wall time per simulated "
             "second.")  # fmt: skip

    def lead(r):
        return [r["control"], f"{r['real_time_factor']:.2f}x", f"{r['solves']:.0f}"]

    return _table(title, ["control", "real time", "QP solves per s"], ms, "completed", rows, lead,
                  "completed")  # fmt: skip


def _table(title: str, head: list, ms, last: str, rows, lead, done: str) -> str:
    """A Markdown table of a benchmark's runs: ``title``, then a row per run of its ``lead``
    cells (``head``), its parts ``ms`` ((key, label): seconds per simulated second, shown in
    milliseconds), and whether ``done`` (the column ``last``)."""
    lines = [
        title,
        "",
        "| " + " | ".join([*head, *(label for _, label in ms), last]) + " |",
        "|---" * (len(ms) + len(head) + 1) + "|",
    ]
    for r in rows:
        cells = [*lead(r), *(f"{r[k] * 1e3:.1f}" for k, _ in ms), "yes" if r[done] else "no"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def run_walk_benchmark(quick: bool = False, out: str | Path = "results/bench") -> int:
    """Time the welded walk, its pieces and the bare plant, and the person's walk and its
    pieces; print the tables, write ``walk.csv`` and ``walk.md``, ``person.csv`` and
    ``person.md``."""

    from ..provenance import machine
    from ..walking.plan import GaitParameters
    from ..walking.run import CONTROL_PERIOD

    h = load_male()
    gait = GaitParameters(steps=4 if quick else 10)
    rows = []
    for control in (CONTROL_PERIOD, 1e-3):
        seconds, result, samples = _timed_walk(h, gait, control)
        simulated = result.summary["simulated"]
        bare = _bare_plant(h.model, samples, 1e-3, 3 if quick else 7) * 1000.0  # per sim s
        per = {k: v / simulated for k, v in seconds.items()}
        qp = per.get("qp_tick", 0.0)
        row = {
            "control": f"{control * 1e3:g} ms",
            "real_time_factor": simulated / seconds["wall"],
            "wall": per["wall"],
            "bare_plant": bare,
            "ratio": per["wall"] / bare,
            "qp_assembly": qp - per.get("qp_solve", 0.0) - per.get("joint_ranges", 0.0),
            "joint_ranges": per.get("joint_ranges", 0.0),
            "qp_solve": per.get("qp_solve", 0.0),
            "held": per.get("held", 0.0),
            "plant": per.get("plant", 0.0),
            "checks": per.get("checks", 0.0),
            "records": per.get("records", 0.0),
            "checks_passed": result.ok,
        }
        row["other"] = row["wall"] - sum(
            row[k] for k in ("qp_assembly", "joint_ranges", "qp_solve", "held", "plant",
                             "checks", "records")
        )  # fmt: skip
        rows.append(row)
        print(f"control every {row['control']}: {result.summary['simulated']:.2f} s walked in "
              f"{seconds['wall']:.2f} s ({row['real_time_factor']:.1f}x real time), "
              f"{row['ratio']:.1f}x the bare plant; every check passed: {result.ok}")  # fmt: skip
    write_table(out, "walk", rows, WALK_COLUMNS, _markdown(rows, machine(), gait.steps))
    steps = 2 if quick else 10
    person = _person_rows(h, steps)
    write_table(out, "person", person, PERSON_COLUMNS, _person_markdown(person, machine(), steps))
    return 0


def _markdown(rows, where: str, steps: int) -> str:
    ms = [
        ("wall", "wall"),
        ("bare_plant", "bare plant"),
        ("qp_assembly", "QP assembly"),
        ("joint_ranges", "range rows"),
        ("qp_solve", "QP solve"),
        ("held", "held forces"),
        ("plant", "plant"),
        ("checks", "checks"),
        ("records", "records"),
        ("other", "other"),
    ]
    title = (f"Measured by `humanoid bench walk` on {where}: the male body's welded walk, {steps} "
             "steps; milliseconds of wall time per simulated second.")  # fmt: skip

    def lead(r):
        return [r["control"], f"{r['real_time_factor']:.1f}x", f"{r['ratio']:.1f}"]

    return _table(title, ["control", "real time", "x bare plant"], ms, "checks pass", rows, lead,
                  "checks_passed")  # fmt: skip
