"""Recorded runs: :class:`Trajectory` (saved as .npz), the preallocated recorder and the
progress bar of long runs."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import pinocchio as pin

from .errors import TrajectoryError
from .linalg import cross
from .run_metadata import RunMetadata

__all__ = ["Trajectory"]


@dataclass(frozen=True)
class Trajectory:
    """A recorded run.

    Attributes:
        t: Record times [s], shape (N,).
        q: Configurations, (N, nq). v: velocities, (N, nv). tau: applied joint torques, (N, nv).
        forces: Contact forces by name, world axes: per foot a wrench (fx, fy, fz, tx, ty, tz)
            about the sole frame origin; per point contact a force (fx, fy, fz); NaN while the
            contact is released. With ground contact, ``ground``: the floor's total force on
            the body and its moment about the world origin (centre of pressure
            (-ty / fz, tx / fz, 0)), the mean over the step that follows the record;
            ``ground_left|right`` per leg, ``joint_ranges`` the ranges' moments (nv). With
            welded feet that have toes, ``foot_locks``: the moments that hold their hinges
            locked (nv; with ``tau``, what the hinges carried).
        energy: Kinetic + potential energy [J], (N,).
        residual: Largest constraint position residual [m or rad] at each record, (N,).
        metadata: Model, joint and contact names, dt, scene, events, statistics, status.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    forces: dict[str, np.ndarray]
    energy: np.ndarray
    residual: np.ndarray
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        for a in (
            self.t,
            self.q,
            self.v,
            self.tau,
            self.energy,
            self.residual,
            *self.forces.values(),
        ):
            a.flags.writeable = False

    @property
    def status(self) -> str:
        return self.metadata.get("status", "completed")

    def save(self, path: str | Path) -> Path:
        """Write an .npz file (arrays, and the metadata as JSON: :meth:`RunMetadata.to_npz`)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {"t": self.t, "q": self.q, "v": self.v, "tau": self.tau}
        arrays |= {"energy": self.energy, "residual": self.residual}
        arrays |= {f"force/{k}": a for k, a in self.forces.items()}
        meta = RunMetadata.from_dict(self.metadata, f"trajectory {path}").to_npz()
        # numpy's stubs read any ** as possibly allow_pickle (a bool)
        np.savez_compressed(path, **meta, **arrays)  # type: ignore[arg-type]
        return path

    @classmethod
    def load(cls, path: str | Path) -> Trajectory:
        """Read a run saved by :meth:`save`.

        Raises:
            TrajectoryError: naming the file: missing, not an .npz, truncated, an array
                missing or of the wrong shape, non-finite states, unreadable metadata.
        """
        try:
            with np.load(path, allow_pickle=False) as z:
                forces = {k[6:]: z[k] for k in z.files if k.startswith("force/")}
                arrays = [z[k] for k in ("t", "q", "v", "tau", "energy", "residual")]
                meta = RunMetadata.from_npz(z, f"trajectory {path}").as_dict()
        except TrajectoryError:
            raise
        except FileNotFoundError:
            raise TrajectoryError(f"trajectory file not found: {path}") from None
        except Exception as exc:  # noqa: BLE001 - numpy's parser of a corrupt header raises
            # anything (OSError, ValueError, zipfile.BadZipFile, zlib.error, SyntaxError,
            # tokenize.TokenError...): every one means the file is not a run
            raise TrajectoryError(
                f"cannot read trajectory {path}: {type(exc).__name__}: {exc}"
            ) from None
        t, q, v, tau, energy, residual = arrays
        _check_run(path, t, q, v, tau, energy, residual, forces, meta)
        return cls(t, q, v, tau, forces, energy, residual, meta)


def _check_run(path, t, q, v, tau, energy, residual, forces, meta) -> None:
    """The arrays of a saved run fit together; states are finite (forces may hold NaN: a
    released contact)."""

    def bad(why) -> NoReturn:
        raise TrajectoryError(f"trajectory {path} is inconsistent: {why}")

    if not isinstance(meta, dict):
        bad("its metadata is not a table")
    if t.ndim != 1:
        bad(f"t has shape {t.shape}")
    n = len(t)
    for name, a, dims in (("q", q, 2), ("v", v, 2), ("tau", tau, 2), ("energy", energy, 1),
                          ("residual", residual, 1)):  # fmt: skip
        if a.ndim != dims or a.shape[0] != n or a.dtype.kind != "f":
            bad(f"{name} has shape {a.shape} and type {a.dtype} for {n} records")
    if v.shape != tau.shape:
        bad(f"v {v.shape} and tau {tau.shape} differ")
    for name, size in (("nq", q.shape[1]), ("nv", v.shape[1])):
        if name in meta and meta[name] != size:
            bad(f"its metadata says {name} = {meta[name]}, its arrays {size}")
    for name, a in (("t", t), ("q", q), ("v", v), ("tau", tau), ("energy", energy)):
        if not np.all(np.isfinite(a)):
            bad(f"{name} has non-finite entries")
    for name, a in forces.items():
        if a.ndim != 2 or a.shape[0] != n or a.dtype.kind != "f":
            bad(f"force {name!r} has shape {a.shape}")


class Progress:
    """A tqdm bar that appears only on a terminal, and only once a run takes > 2 s."""

    def __init__(self, total: int, quiet: bool) -> None:
        self.total = total
        self.bar: Any = None  # a tqdm bar, once the run has lasted 2 s
        self.enabled = not quiet and sys.stderr.isatty()
        self.start = time.perf_counter()

    def update(self, n: int) -> None:
        if not self.enabled or n % 64:
            return
        if self.bar is None:
            if time.perf_counter() - self.start < 2.0:
                return
            from tqdm import tqdm

            self.bar = tqdm(total=self.total, unit="step", file=sys.stderr, initial=n)
        self.bar.n = n
        self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class Recorder:
    """Preallocated record arrays."""

    def __init__(self, n: int, model, contacts, ground: bool = False, legs=None) -> None:
        self.n = 0
        self.velocity_residual = 0.0  # largest |J v| of the active constraints at the records
        self.t = np.zeros(n)
        self.q = np.zeros((n, model.nq))
        self.v = np.zeros((n, model.nv))
        self.tau = np.zeros((n, model.nv))
        self.energy = np.zeros(n)
        self.residual = np.zeros(n)
        self.forces = {}
        if ground:
            # total ground force and its moment about the world origin, world axes [N, N m]
            self.forces["ground"] = np.zeros((n, 6))
            # the floor's force on each leg (the joints from its hip down) and its moment about
            # the world origin, the impulses at their own points (an exact wrench: what inverse
            # dynamics applies), and the joint ranges' moments in generalised coordinates
            self.legs = legs or {}
            # each leg's joints as a lookup by joint (a step's points are sorted by a gather)
            self._leg_of = {side: np.isin(np.arange(model.njoints), joints)
                            for side, joints in self.legs.items()}  # fmt: skip
            for side in self.legs:
                self.forces[f"ground_{side}"] = np.zeros((n, 6))
            self.forces["joint_ranges"] = np.zeros((n, model.nv))
        # the moments with which welded feet hold their own hinges (the toes' MTP) locked, in
        # generalised coordinates: with the controller's torques, what the hinges carried
        self._locks = [(c, [model.joints[j].idx_v for j in c.hinges]) for c in contacts
                       if c.spec.kind == "weld" and len(c.hinges)]  # fmt: skip
        if self._locks:
            self.forces["foot_locks"] = np.zeros((n, model.nv))
        for c in contacts:
            self.forces[c.side] = np.full((n, 6), np.nan)
            if c.spec.kind == "points":
                for name in ("heel_inner", "heel_outer", "toe_inner", "toe_outer"):
                    self.forces[f"{c.side}_{name}"] = np.full((n, 3), np.nan)

    def add(self, sim, t, q, v, step) -> None:
        """Record the state at t, and the torques and forces with which ``step`` (the
        :class:`~humanoid.simulation.StepResult` of the step from it) started."""
        i = self.n
        if i >= len(self.t):
            return
        model, data = sim.model, sim.data
        self.t[i], self.q[i], self.v[i] = t, q, v
        self.tau[i] = step.torque
        self.energy[i] = pin.computeKineticEnergy(model, data, q, v) + pin.computePotentialEnergy(
            model, data, q
        )
        found = getattr(sim, "ground_step", None)
        if found is not None and "ground" in self.forces:
            self.forces["ground"][i] = found.wrench / sim.scene.dt
            for side, leg in self._leg_of.items():
                mine = leg[found.joints]
                f, p = found.impulses[mine] / sim.scene.dt, found.points[mine]
                self.forces[f"ground_{side}"][i, :3] = f.sum(axis=0)
                self.forces[f"ground_{side}"][i, 3:] = cross(p, f).sum(axis=0)
            if found.limit_generalized is not None:
                self.forces["joint_ranges"][i] = found.limit_generalized / sim.scene.dt
        constraints = sim.active_constraints()
        if constraints:
            sim.kinematics(q, v)
            if step.solution is not None:
                sim.store_forces(step.solution)
            e = np.concatenate([c.residual(model, data) for c in constraints])
            self.residual[i] = np.abs(e).max()
            Jv = np.concatenate([c.jacobian(model, data) @ v for c in constraints])
            self.velocity_residual = max(self.velocity_residual, float(np.abs(Jv).max()))
        for c, idx in self._locks:
            if c.attached:
                self.forces["foot_locks"][i, idx] = c.lock_torques
        for c in sim.contacts:
            if c.attached:
                self.forces[c.side][i] = c.wrench
                if c.spec.kind == "points":
                    for j, name in enumerate(
                        ("heel_inner", "heel_outer", "toe_inner", "toe_outer")
                    ):
                        self.forces[f"{c.side}_{name}"][i] = c.point_forces[j]
        self.n += 1

    def trajectory(self, meta) -> Trajectory:
        """The records as a Trajectory: views of the preallocated arrays, no copy (a copy
        would double the memory of a long run at its very end)."""
        n = self.n
        forces = {k: a[:n] for k, a in self.forces.items()}
        return Trajectory(
            self.t[:n], self.q[:n], self.v[:n], self.tau[:n], forces, self.energy[:n],
            self.residual[:n], meta,
        )  # fmt: skip
