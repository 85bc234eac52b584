"""What the benchmarks share: the reference body, record rate, walking segment, running a
scene with its wall time, and the state error against a reference run."""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin

from ..anthropometry import BodyParameters
from ..body import build_urdf
from ..model import load

__all__ = [
    "CONTROL_DT",
    "Clock",
    "MALE",
    "RECORD_RATE",
    "WALK_STEPS",
    "best_time",
    "best_times",
    "load_male",
    "pinocchio_contacts",
    "run_scene",
    "state_error",
    "write_rows",
    "write_table",
]

# The benchmarks' body: the shipped male (1.75 m, 75 kg) with one-piece feet, the body every
# benchmark has measured (the shipped body's toes add the fastest mode of the model: 0.16 kg on
# a hinge; a comparison of integrators or contact solvers on it would measure the toes)
MALE = BodyParameters(1.75, 75.0, "male", toes=False)


def load_male(ball_joints: str = "quaternion"):
    """The benchmarks' body (:data:`MALE`) loaded."""
    return load(build_urdf(MALE), ball_joints=ball_joints)


# Records at 25 Hz: a whole number of steps for every swept dt (8 ms ... 0.5 ms) and for the
# adaptive integrator's 40 ms tick, so that every run is compared at the same instants.
RECORD_RATE = 25.0
WALK_STEPS = 2  # the walking segment: two steps, about 4.4 s
CONTROL_DT = 2e-3  # the walking controller's fixed rate in the benchmark [s]


def run_scene(scene, h):
    """(trajectory, wall time) of a scene."""
    from ..simulation import Simulation

    sim = Simulation(scene, humanoid=h)
    start = time.perf_counter()
    traj = sim.run(quiet=True)
    return traj, time.perf_counter() - start


def state_error(model, ref, qs, vs) -> float:
    """The largest state difference from the reference over the records, on the manifold:
    max(|pin.difference(q_ref, q)|, |v - v_ref|)."""
    return max(
        max(np.abs(pin.difference(model, a, b)).max() for a, b in zip(ref.q, qs, strict=True)),
        float(np.abs(np.asarray(vs) - ref.v).max()),
    )


def best_time(fn, n: int, rounds: int) -> float:
    """Best per-call wall time [s] of ``fn()`` over ``rounds`` rounds of ``n`` calls (the
    machine is shared and noisy: the best round is the least disturbed), on one BLAS/OpenMP
    thread as a simulation runs (:meth:`~humanoid.simulation.Simulation.run`)."""
    from ..linalg import one_thread

    best = float("inf")
    with one_thread():
        for _ in range(rounds):
            start = time.perf_counter()
            for _ in range(n):
                fn()
            best = min(best, (time.perf_counter() - start) / n)
    return best


def best_times(fns: dict, n: int, rounds: int) -> dict:
    """:func:`best_time` of several functions with their rounds interleaved (round 1 of each,
    then round 2 of each...): a machine that slows down for a while slows them all, and the
    ratios between them stay what they are."""
    best = dict.fromkeys(fns, float("inf"))
    for _ in range(rounds):
        for name, fn in fns.items():
            best[name] = min(best[name], best_time(fn, n, 1))
    return best


def pinocchio_contacts(model, data, welds=(), points=()):
    """Pinocchio's own rigid constraint models and their datas, built with its API alone (the
    reference the benchmarks time ours against): each frame id in ``welds`` welded in 6D
    (LOCAL) where ``data.oMf`` has it, each in ``points`` pinned in 3D (world axes) where it
    is. ``data`` must hold the frames' placements."""
    cms = pin.StdVec_RigidConstraintModel()
    for frames, kind, ref in (
        (welds, pin.ContactType.CONTACT_6D, pin.LOCAL),
        (points, pin.ContactType.CONTACT_3D, pin.LOCAL_WORLD_ALIGNED),
    ):
        for f in frames:
            fr = model.frames[f]
            anchor = data.oMf[f] if kind == pin.ContactType.CONTACT_6D else pin.SE3(
                np.eye(3), data.oMf[f].translation)  # fmt: skip
            cms.append(pin.RigidConstraintModel(kind, model, fr.parentJoint, fr.placement, 0,
                                                anchor, ref))  # fmt: skip
    cds = pin.StdVec_RigidConstraintData()
    for cm in cms:
        cds.append(cm.createData())
    return cms, cds


def write_rows(path, rows, columns=None) -> None:
    """``rows`` (dicts) as a CSV file with a header (``columns``, default the first row's keys,
    in that order; other keys are left out)."""
    import csv

    columns = list(columns or rows[0])
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)


def write_table(out, name: str, rows, columns, text: str) -> None:
    """A benchmark's rows as ``<out>/<name>.csv`` and its table ``text`` as ``<name>.md``,
    the table printed (the folder made if needed)."""
    from pathlib import Path

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    write_rows(folder / f"{name}.csv", rows, columns)
    (folder / f"{name}.md").write_text(text)
    print(text)
    print(f"wrote {folder / f'{name}.csv'} and {folder / f'{name}.md'}")


class Clock:
    """Accumulated wall time of wrapped callables, by label."""

    def __init__(self) -> None:
        self.total: dict[str, float] = {}

    def timed(self, fn, label: str):
        """``fn`` with its wall time added to ``label``'s."""

        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.total[label] = self.total.get(label, 0.0) + time.perf_counter() - start

        return timed

    def wrap(self, owner, name: str, label: str) -> None:
        """Time ``owner.name`` under ``label`` from now on."""
        setattr(owner, name, self.timed(getattr(owner, name), label))
