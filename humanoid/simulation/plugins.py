"""What a run's plug-ins look like and what they are shown: a controller gives torques, a
schedule says when contacts attach and release, a monitor observes every step (the
:class:`StepResult` of each). Each is handed to :meth:`~humanoid.simulation.Simulation.run`,
never set on the simulation; ``sim``, in their methods, is that
:class:`~humanoid.simulation.Simulation`."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np
import pinocchio as pin

if TYPE_CHECKING:
    from ..constraints.native import NativeSolution
    from ..constraints.solve import ConstrainedAcceleration

__all__ = ["Controller", "Monitor", "Schedule", "StepResult"]


class StepResult:
    """One step of the plant (read-only by convention: a plain slotted class, built every
    step, costs a quarter of a frozen dataclass).

    Attributes:
        t: Time at the end of the step [s].
        q, v: The state at the end of the step ((x, x') in the coordinate formulation).
        torque: The joint torques at the start of the step (what the records call tau).
        solution: The constrained solve at the start of the step (its accelerations and
            contact forces), or None when no contact was attached.
    """

    __slots__ = ("t", "q", "v", "torque", "solution")

    def __init__(self, t: float, q: np.ndarray, v: np.ndarray, torque: np.ndarray,
                 solution: ConstrainedAcceleration | NativeSolution | None,
                 ) -> None:  # fmt: skip
        self.t, self.q, self.v, self.torque, self.solution = t, q, v, torque, solution


class Controller(Protocol):
    """Joint torques for the plant: the posture hold, the walking controller, a tracker.

    ``before_step`` runs once per step before it (a controller's QP tick reads the plant's
    stance there); ``force`` is the generalised force at any stage of the step (masked off the
    free flyer by the plant); ``implicit`` gives the stiffness and damping that the ground
    contact's step takes implicitly, or None (:meth:`humanoid.effects.Effect.implicit`).
    """

    def before_step(self, sim, k: int, t: float, q: np.ndarray,
                    v: np.ndarray) -> None: ...  # fmt: skip

    def force(self, model: pin.Model, data: pin.Data, t: float, q: np.ndarray,
              v: np.ndarray) -> np.ndarray | None: ...  # fmt: skip

    def implicit(self, nv: int) -> tuple[np.ndarray, np.ndarray] | None: ...


class Schedule(Protocol):
    """A contact schedule, called at every tick k before the step: returns v, after the
    impulse of any contact that attached (v itself if none did)."""

    def __call__(self, sim, k: int, t: float, q: np.ndarray, v: np.ndarray,
                 last: StepResult | None) -> np.ndarray: ...  # fmt: skip


class Monitor(Protocol):
    """Observes every step (the state at its start and ``step``, its result); raising
    :class:`~humanoid.errors.RunFailed` stops the run as failed."""

    def observe(self, sim, k: int, t: float, q: np.ndarray, v: np.ndarray,
                step: StepResult) -> None: ...  # fmt: skip
