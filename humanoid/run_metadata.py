"""What a saved run says about itself: :class:`RunMetadata`, the typed record of a run's .npz
(its status, body, sizes, scene, events and statistics), written by :meth:`RunMetadata.to_npz`
and read by :meth:`RunMetadata.from_npz`, which also reads the files written before it (a
flat JSON table under ``metadata``).

In memory a :class:`~humanoid.trajectory.Trajectory` keeps its metadata as that table
(:meth:`RunMetadata.as_dict`), which a walk extends with its own keys (its gait, footsteps...):
those travel in :attr:`RunMetadata.extra`.
"""

from __future__ import annotations

import json
import numbers
from dataclasses import dataclass, field, fields

import numpy as np

from .errors import TrajectoryError

__all__ = ["FORMAT", "RunMetadata"]

FORMAT = 2  # the layout RunMetadata.to_npz writes (1: the flat table of the first versions)


@dataclass(frozen=True)
class RunMetadata:
    """The metadata of a recorded run; a field is None where the run did not record it (a
    run made of joint coordinates has a model and a status only).

    Attributes:
        status: ``completed``, ``failed``, ``diverged`` or ``interrupted``.
        message: Why it stopped early ("" when it completed).
        model: The file the body came from. body: Its recipe
            (:func:`humanoid.model.load_recipe` loads it again).
        ball_joints: ``quaternion`` or ``euler``. nq, nv: The model's sizes.
        joint_names: The model's joints, the universe first. contacts: Each contact's
            constraints by side. feet: The sole frames (left, right).
        dt: The step [s]. record_rate: Records per second [Hz]. scene: The scene, as a table.
        events: Contact events (touchdowns, releases, gimbal locks...), each a table.
        violations: Count of force-check violations by kind. counters: Dynamics evaluations.
        steps: Steps run. wall_time: [s]. max_residual: Largest constraint position error
            [m or rad]. max_velocity_residual: Largest ``|J v|`` [m/s or rad/s].
            quaternion_drift: Largest quaternion norm error.
        max_penetration: [m], contact_solver_failures and contact_solver_fallbacks (the steps
            the compiled solver handed to Pinocchio's ADMM): with ground contact.
        adaptive: An adaptive integrator's counters.
        extra: Keys this record does not type (a walk's gait, footsteps, weight...), and
            typed ones recorded as null.
    """

    status: str | None = None
    message: str | None = None
    model: str | None = None
    body: dict | None = None
    ball_joints: str | None = None
    nq: int | None = None
    nv: int | None = None
    joint_names: tuple[str, ...] | None = None
    contacts: dict | None = None
    feet: tuple[str, ...] | None = None
    dt: float | None = None
    record_rate: float | None = None
    scene: dict | None = None
    events: tuple[dict, ...] | None = None
    violations: dict | None = None
    counters: dict | None = None
    steps: int | None = None
    wall_time: float | None = None
    max_residual: float | None = None
    max_velocity_residual: float | None = None
    quaternion_drift: float | None = None
    max_penetration: float | None = None
    contact_solver_failures: int | None = None
    contact_solver_fallbacks: int | None = None
    adaptive: dict | None = None
    extra: dict = field(default_factory=dict)

    @classmethod
    def from_dict(cls, table, where: str = "the run") -> RunMetadata:
        """The record of a metadata table (a Trajectory's, or a file's of the first layout):
        its known keys typed, the others in :attr:`extra`.

        Raises:
            TrajectoryError: ``table`` is not a table, or a known key has the wrong type.
        """
        if not isinstance(table, dict):
            raise TrajectoryError(f"{where}: its metadata is not a table")
        known = {f.name for f in fields(cls)} - {"extra"}
        typed = {k: _typed(k, v, where) for k, v in table.items() if k in known and v is not None}
        return cls(**typed, extra={k: v for k, v in table.items() if k not in typed})

    def as_dict(self) -> dict:
        """The flat table a Trajectory keeps (the recorded fields, then :attr:`extra`), as
        JSON gives it back: sequences as lists."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name != "extra" and value is not None:
                out[f.name] = list(value) if isinstance(value, tuple) else value
        return out | self.extra

    def to_npz(self) -> dict[str, np.ndarray]:
        """The arrays that store it in a run's .npz: ``metadata``, JSON of ``{"format": 2,
        "run": the recorded fields, "extra": the other keys}``."""
        run = {k: v for k, v in self.as_dict().items() if k not in self.extra}
        text = json.dumps({"format": FORMAT, "run": run, "extra": self.extra})
        return {"metadata": np.array(text)}

    @classmethod
    def from_npz(cls, arrays, where: str = "the run") -> RunMetadata:
        """The record stored in a run's .npz (``arrays``: its ``np.load``), of either layout.

        Raises:
            TrajectoryError: no metadata, not JSON, not a table, a field of the wrong type, or
                a format this version does not read.
        """
        try:
            table = json.loads(str(arrays["metadata"]))
        except KeyError:
            raise TrajectoryError(f"{where} has no metadata") from None
        except (ValueError, TypeError, RecursionError) as exc:
            raise TrajectoryError(f"{where}: its metadata is not JSON: {exc}") from None
        if not isinstance(table, dict) or "format" not in table:
            return cls.from_dict(table, where)  # the first layout: one flat table
        if table["format"] != FORMAT or not isinstance(table.get("run"), dict):
            raise TrajectoryError(f"{where}: metadata of format {table['format']!r}; this "
                                  f"version reads formats 1 and {FORMAT}")  # fmt: skip
        extra = table.get("extra", {})
        if not isinstance(extra, dict):
            raise TrajectoryError(f"{where}: its metadata's 'extra' is not a table")
        return cls.from_dict(table["run"] | extra, where)


# the type of each recorded field: how a table's value is checked and stored
_KINDS = {"status": str, "message": str, "model": str, "ball_joints": str, "nq": int, "nv": int,
          "steps": int, "contact_solver_failures": int, "contact_solver_fallbacks": int,
          "dt": float, "record_rate": float,
          "wall_time": float, "max_residual": float, "max_velocity_residual": float,
          "quaternion_drift": float, "max_penetration": float, "body": dict, "contacts": dict,
          "scene": dict, "violations": dict, "counters": dict, "adaptive": dict,
          "joint_names": tuple, "feet": tuple, "events": tuple}  # fmt: skip


def _typed(key: str, value, where: str):
    """A recorded field's value checked against its kind (a number of either kind for a
    float; a list or tuple for a sequence, stored as a tuple)."""
    kind = _KINDS[key]
    ok = {
        str: isinstance(value, str),
        int: isinstance(value, numbers.Integral) and not isinstance(value, bool),
        float: isinstance(value, numbers.Real) and not isinstance(value, bool),
        dict: isinstance(value, dict),
        tuple: isinstance(value, list | tuple),
    }[kind]
    if not ok:
        raise TrajectoryError(
            f"{where}: its metadata's {key!r} is {type(value).__name__} {value!r:.60}, not "
            f"{'a sequence' if kind is tuple else kind.__name__}"
        )
    if kind is tuple:
        return tuple(value)
    return kind(value) if kind in (int, float) else value
