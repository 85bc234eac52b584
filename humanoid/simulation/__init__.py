"""The run loop: a :class:`Scene` in, a :class:`Trajectory` out. Every simulation, the walk
included, is stepped by :meth:`Simulation.run`.

What a run does is plugged into the one loop: effects (pushes, damping, springs) and a
controller (the posture hold, the walking controller) give torques; a contact schedule says when
contacts attach and release (the scene's windows and touchdowns by default; a footstep plan for
the walk); monitors observe every step (the walk's checks) and may stop the run. The
controller, the schedule and the monitors are arguments of :meth:`Simulation.run`
(:mod:`~humanoid.simulation.plugins`).

The package, one module a stage:

- :mod:`~humanoid.simulation.setup`: the scene and its body -> the model, the initial state,
  the effects, the contacts, the ground's solve, the scene's controller, and the variants'
  implementations from their registries (:mod:`~humanoid.simulation.integration`,
  :mod:`~humanoid.simulation.formulation`, :mod:`~humanoid.simulation.backends`). The body is
  built once a run, and the scene checked against it there.
- :mod:`~humanoid.simulation.plant`: one step -> a :class:`StepResult`. Effects -> tau; bias
  b(q, v) as far as the scene needs it (no gravity term without gravity, nothing
  velocity-dependent without Coriolis terms); plain ABA when no contact is attached, else the
  constrained solve; then the integrator (or the ground contact's velocity-level step,
  :mod:`~humanoid.simulation.ground`).
- :mod:`~humanoid.simulation.contacts`: after each step, contact checks (unilaterality,
  friction, centre of pressure) that release unilateral contacts, touchdown that attaches them
  again with an impulse, the optional projection on the constraint manifold.
- :mod:`~humanoid.simulation.loop`: :class:`Simulation` and the loop itself, with the
  divergence guard. Records are taken at ``record_rate`` into preallocated arrays, so memory
  is fixed by the duration and a run does not slow down as it goes.
"""

from __future__ import annotations

from ..contacts import ContactState
from ..trajectory import Progress, Recorder, Trajectory
from .loop import MAX_SPEED, Simulation, check_divergence, scene_schedule, simulate
from .plugins import Controller, Monitor, Schedule, StepResult
from .setup import Setup, check_scene, load_body

__all__ = [
    "MAX_SPEED",
    "ContactState",
    "Controller",
    "Monitor",
    "Progress",
    "Recorder",
    "Schedule",
    "Setup",
    "Simulation",
    "StepResult",
    "Trajectory",
    "check_divergence",
    "check_scene",
    "load_body",
    "scene_schedule",
    "simulate",
]
