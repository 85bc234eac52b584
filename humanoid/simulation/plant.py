"""The plant: one step of the body, from (t, q, v) to a :class:`StepResult`.

One step: effects and controller -> tau; bias b(q, v) as far as the scene needs it (no
gravity term without gravity, nothing velocity-dependent without Coriolis terms); plain ABA
when no contact is attached, else the constrained solve of the scene's backend; then the
scene's integrator, or the ground contact's velocity-level step.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ..constraints.native import NativeSolution
from .contacts import ContactBook
from .ground import GroundStep
from .plugins import Controller, StepResult
from .setup import Setup

if TYPE_CHECKING:
    from ..constraints.solve import ConstrainedAcceleration

    # a solve: (joint torques, constrained solution or None)
    Solved = tuple[np.ndarray, ConstrainedAcceleration | NativeSolution | None]

__all__ = ["Plant"]

# ABA's world-frame variant: the same accelerations (to 1e-12), 10 % faster on the bodies here
# (the contact-free path of a scene with nothing else; elsewhere the local one, whose
# round-off the ground scenes' resting states were checked with)
_WORLD = pin.Convention.WORLD


class Plant:
    """The body of a set-up driven by a controller (or none): forces, dynamics, one step.

    Args:
        setup: The scene on its body.
        book: The contacts' bookkeeping (which are attached).
        controller: What gives the joint torques (:class:`~.plugins.Controller`), or None.
        counters: Where the plant counts its solves (ABA, KKT, bias terms).
    """

    def __init__(self, setup: Setup, book: ContactBook, controller: Controller | None,
                 counters: dict) -> None:  # fmt: skip
        self.book, self.controller, self.counters = book, controller, counters
        self.model, self.data, self.mask = setup.model, setup.data, setup.mask
        self.effects, self.contacts = setup.effects, setup.contacts
        self.baumgarte = setup.baumgarte
        self.velocity_terms = setup.scene.effects.coriolis
        self.has_gravity = setup.has_gravity
        formulation, integrator = setup.formulation, setup.integrator
        self.space, self.integrator = formulation.space, integrator
        self.ground = GroundStep(self, setup.ground) if setup.ground is not None else None
        self.constrained = setup.backend(self)
        self.last: Solved | None = None  # the last solve
        self._tick = 0.0
        self._zero = np.zeros(self.model.nv)
        self._zero.flags.writeable = False
        self.joint_torque = self._zero
        self._first: Solved | None = None
        self._frozen = False
        self._dynamics = formulation.dynamics(self)
        # semi-implicit Euler on the Lie group without the ground's velocity-level solve: one
        # evaluation per step, inlined in :meth:`step`
        lie, no_ground = formulation.lie_group, setup.ground is None
        self._euler = integrator.inline_euler and lie and no_ground
        # a fixed-step scheme on the Lie group with no contact ever and all velocity terms:
        # ABA alone, while no effect or controller is plugged in (checked at each step)
        self._free = integrator.fixed and lie and not self.contacts and no_ground
        self._free = self._free and self.velocity_terms

    @property
    def ground_step(self):
        """What the ground contact's solve found in the last step, or None."""
        return self.ground.found if self.ground is not None else None

    # -- forces --------------------------------------------------------------------------
    def applied(self, t, q, v) -> np.ndarray:
        """Generalised force of the effects and the controller.

        Joint efforts (damping, springs, limits, the controller) are masked off the free
        flyer; external ones (pushes) act on every row. The joint part is kept in
        ``self.joint_torque`` (what the records call tau).

        Time-dependent effects (pushes) are sampled at the start of the step, like a
        controller: a push that ends exactly at a step boundary would otherwise switch off
        inside the step's last stage, and an adaptive step could never resolve it.
        """
        if not self.effects and self.controller is None:
            self.joint_torque = self._zero
            return self._zero
        t, model, data = self._tick, self.model, self.data
        tau = external = None
        if self.controller is not None:
            tau = self.controller.force(model, data, t, q, v)
        for eff in self.effects:
            f = eff.force(model, data, t, q, v)
            if f is None:  # nothing this step (a push outside its window, ranges clear)
                continue
            if eff.external:
                external = f if external is None else external + f
            else:
                tau = f if tau is None else tau + f
        # masked into a new array: a controller may hand out its own buffer
        tau = self._zero if tau is None else tau * self.mask
        self.joint_torque = tau
        return tau if external is None else tau + external

    def bias(self, q, v) -> np.ndarray:
        """b(q, v) with only the terms the scene calls for."""
        if self.velocity_terms:
            self.counters["bias"] += 1
            return pin.nle(self.model, self.data, q, v)  # gravity is zero in the model if off
        if self.has_gravity:
            self.counters["gravity"] += 1
            return pin.computeGeneralizedGravity(self.model, self.data, q)
        return np.zeros(self.model.nv)

    # -- dynamics ------------------------------------------------------------------------
    def acceleration(self, t, q, v) -> np.ndarray:
        """dv/dt for the Lie-group formulation."""
        if self.effects or self.controller is not None:
            tau = self.applied(t, q, v)
        else:
            tau = self.joint_torque = self._zero
        constraints = self.book.active_constraints()
        if not constraints:
            self.counters["aba"] += 1
            self.last = (self.joint_torque, None)
            # a new array (Pinocchio's bindings copy data.ddq out)
            return pin.aba(self.model, self.data, q, v if self.velocity_terms else self._zero, tau)
        self.counters["kkt"] += 1
        return self.constrained(q, v, tau, constraints)

    def aba(self, t, q, v) -> np.ndarray:
        """dv/dt of a scene without contacts, effects or controller: ABA (a new array)."""
        self.counters["aba"] += 1
        return pin.aba(self.model, self.data, q, v, self._zero, _WORLD)

    # -- one step ------------------------------------------------------------------------
    def step(self, t: float, q, v, dt: float) -> StepResult:
        """Advance (q, v) (or (x, x') in the coordinate formulation) by dt."""
        self._tick = t
        # nothing but ABA (no contact ever, no effect or controller plugged in): called directly
        aba_only = self._free and not self.effects and self.controller is None
        if self._euler:  # semi-implicit Euler on the Lie group, inlined (the hot path)
            if aba_only:
                a = self.aba(t, q, v)
                self.last = (self._zero, None)
            else:
                a = self.acceleration(t, q, v)
            assert self.last is not None  # set by aba or acceleration just above
            torque, solution = self.last
            v_new = v + dt * a
            return StepResult(t + dt, pin.integrate(self.model, q, dt * v_new), v_new, torque,
                              solution)  # fmt: skip
        self._first = None
        self._frozen = False
        if self.ground is not None:
            q_new, v_new = self.ground.advance(t, q, v, dt)
            self._first = self.last
        elif aba_only:
            q_new, v_new = self.integrator.advance(self.space, self.aba, t, q, v, dt)
            self.last = self._first = (self._zero, None)
        else:
            q_new, v_new = self.integrator.advance(self.space, self._capture, t, q, v, dt)
        return self._result(t + dt, q_new, v_new)

    def evaluate(self, t: float, q, v) -> StepResult:
        """The torques and the constrained solve at (t, q, v) without advancing: what a step
        from here would start with (the last record of a run)."""
        self._tick = t
        self._dynamics(t, q, v)
        self._first = self.last
        return self._result(t, q, v)

    def _result(self, t, q, v) -> StepResult:
        torque, solution = self._first if self._first is not None else (self._zero, None)
        return StepResult(t, q, v, torque, solution)

    def _capture(self, t, q, v):
        """The dynamics, keeping the first evaluation of a step (the state at its start)."""
        if self._first is not None and not self._frozen:
            # a later stage is about to overwrite Pinocchio's contact data: read it now
            if isinstance(self._first[1], NativeSolution):
                self._first[1].freeze()
            self._frozen = True
        a = self._dynamics(t, q, v)
        if self._first is None:
            self._first = self.last
        return a
