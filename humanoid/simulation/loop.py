"""The one run loop: :class:`Simulation` (a scene set up on its body) and :meth:`Simulation.run`
(every tick: the contact schedule, the controller's update, one step of the plant, the
record, the monitors, the divergence guard, the optional projection)."""

from __future__ import annotations

import math
import time

import numpy as np

from ..errors import DivergenceError, HumanoidError
from ..linalg import one_thread
from ..model import Humanoid
from ..scene import Scene
from ..trajectory import Progress, Recorder, Trajectory
from .contacts import ContactBook
from .plant import Plant
from .plugins import Controller, Monitor, Schedule, StepResult
from .setup import Setup

__all__ = ["MAX_SPEED", "Simulation", "check_divergence", "scene_schedule", "simulate"]

MAX_SPEED = 1e4  # [m/s or rad/s] beyond this the state counts as diverged


class Simulation:
    """A scene made ready to run: its body, model, effects, contacts, integrator
    (:class:`~.setup.Setup`), the contacts' bookkeeping (:class:`~.contacts.ContactBook`) and
    the plant that steps it (:class:`~.plant.Plant`).

    What a run does beyond the scene is handed to :meth:`run`: a controller, a contact
    schedule, monitors, an initial state.
    """

    def __init__(self, scene: Scene, humanoid: Humanoid | None = None) -> None:
        self.setup = setup = Setup(scene, humanoid)  # the one body build, if none is given
        self.scene, self.h = scene, setup.h
        self.model, self.data = setup.model, setup.data
        self.q0, self.v0 = setup.q0, setup.v0  # the scene's initial state
        self.effects, self.contacts, self.ground = setup.effects, setup.contacts, setup.ground
        self.baumgarte, self.formulation = setup.baumgarte, setup.formulation
        self.counters = {"aba": 0, "kkt": 0, "bias": 0, "gravity": 0}
        self.book = ContactBook(setup)
        self.plant = Plant(setup, self.book, setup.controller, self.counters)

    @property
    def n_steps(self) -> int:
        """How many steps of dt the scene's duration takes (at least one)."""
        return max(1, int(round(self.scene.duration / self.scene.dt)))

    @property
    def events(self) -> list[dict]:
        """Contacts attached and released, gimbal locks: the run's log."""
        return self.book.events

    @property
    def ground_step(self):
        """What the ground contact's solve found in the last step, or None."""
        return self.plant.ground_step

    def legs(self) -> dict:
        return self.setup.legs()

    # -- the contacts (:class:`~.contacts.ContactBook`) ----------------------------------
    def kinematics(self, q, v=None) -> None:
        self.book.kinematics(q, v)

    def active_constraints(self) -> list:
        return self.book.active_constraints()

    def store_forces(self, solution) -> None:
        self.book.store_forces(solution)

    def switch_contacts(self, t: float, q, v, stance):
        return self.book.switch_contacts(t, q, v, stance)

    def update_contacts(self, t: float, q, v, last: StepResult | None = None):
        return self.book.update_contacts(t, q, v, last)

    def project(self, q, v):
        return self.book.project(q, v)

    # -- the plant (:class:`~.plant.Plant`) ----------------------------------------------
    def step(self, t: float, q, v, dt: float) -> StepResult:
        """One step from (q, v) at time t (:meth:`.plant.Plant.step`), its dense algebra on
        one thread as in :meth:`run`."""
        with one_thread():
            return self.plant.step(t, q, v, dt)

    def evaluate(self, t: float, q, v) -> StepResult:
        with one_thread():
            return self.plant.evaluate(t, q, v)

    # -- the loop ------------------------------------------------------------------------
    def run(
        self,
        quiet: bool = False,
        *,
        controller: Controller | None = None,
        schedule: Schedule | None = None,
        monitors: list[Monitor] | tuple = (),
        initial: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> Trajectory:
        """Simulate the scene: every tick, the contact schedule, the controller's update, one
        step, the record, the monitors, the divergence guard, the optional projection.

        Args:
            quiet: No progress bar.
            controller: Drives the plant from now on in place of the scene's controller
                (:class:`~.plugins.Controller`).
            schedule: The contact schedule (:class:`~.plugins.Schedule`); default the
                scene's windows and touchdowns (:func:`scene_schedule`).
            monitors: Observe every step (:class:`~.plugins.Monitor`).
            initial: The initial state (q0, v0); default the scene's.

        Stops early, keeping what was computed, on Ctrl-C (status ``interrupted``), on
        divergence (``diverged``: non-finite or exploding state, an adaptive step that will
        not converge) and on any other :class:`~humanoid.errors.HumanoidError` raised inside
        the loop (``failed``: a fall seen by a monitor, a controller without a solution).

        The run's dense algebra (BLAS, LAPACK, OpenMP) uses one thread whatever the
        environment says (:func:`~humanoid.linalg.one_thread`); runs in parallel get their
        threads from a study's workers.
        """
        if controller is not None and controller is not self.plant.controller:
            self.plant = Plant(self.setup, self.book, controller, self.counters)
        q0, v0 = initial if initial is not None else (self.q0, self.v0)
        with one_thread():
            return _run(self, schedule or scene_schedule, list(monitors), q0, v0, quiet)


def _run(sim: Simulation, schedule, monitors, q0, v0, quiet: bool) -> Trajectory:
    scene, plant, formulation = sim.scene, sim.plant, sim.formulation
    dt, n_steps = scene.dt, sim.n_steps
    every = max(1, int(round(1.0 / (scene.record_rate * dt))))
    rec = Recorder(n_steps // every + 1, sim.model, sim.contacts, sim.ground is not None,
                   sim.legs())  # fmt: skip
    controller, book = plant.controller, sim.book
    project = book.project if scene.stabilisation.projection else None

    def scheduled(k, t, x, xd, q, v, last):
        """The contact schedule at tick k; the formulation's state follows an impulse."""
        v_new = schedule(sim, k, t, q, v, last)
        if v_new is v:
            return x, xd, q, v
        return *formulation.state(q, v_new), q, v_new

    t, q, v = 0.0, q0.copy(), v0.copy()
    x, xd = formulation.state(q, v)
    status, message = "completed", ""
    start = time.perf_counter()
    progress = Progress(n_steps, quiet)
    norm_drift = 0.0  # largest | |Q|^2 - 1 | of the coordinate formulation's raw state
    last = None
    k = 0
    try:
        for k in range(n_steps):
            t = k * dt
            x, xd, q, v = scheduled(k, t, x, xd, q, v, last)
            if controller is not None:
                controller.before_step(sim, k, t, q, v)
            last = plant.step(t, x, xd, dt)
            if k % every == 0:
                rec.add(sim, t, q, v, last)
            for monitor in monitors:
                monitor.observe(sim, k, t, q, v, last)
            check_divergence(last.t, last.q, last.v)
            norm_drift = max(norm_drift, formulation.norm_residual(last.q))
            x, xd, q, v = formulation.after_step(last.q, last.v, project)
            if book.gimbal:
                book.watch_gimbal_lock(last.t, q)
            progress.update(k + 1)
        t = n_steps * dt
        x, xd, q, v = scheduled(n_steps, t, x, xd, q, v, last)
        rec.add(sim, t, q, v, plant.evaluate(t, x, xd))
    except KeyboardInterrupt:
        status, message = "interrupted", f"interrupted by the user at t = {t:.4f} s"
    except DivergenceError as exc:
        status, message = "diverged", str(exc)
    except HumanoidError as exc:
        status, message = "failed", str(exc)
    finally:
        progress.close()
    steps = k + 1 if status == "completed" else k
    meta = metadata(sim, rec, status, message, steps, time.perf_counter() - start, norm_drift)
    return rec.trajectory(meta)


def metadata(sim: Simulation, rec: Recorder, status: str, message: str, steps: int,
             wall: float, norm_drift: float) -> dict:  # fmt: skip
    """What a trajectory says about its run."""
    model, h, scene = sim.model, sim.h, sim.scene
    meta = {
        "status": status,
        "message": message,
        "model": h.source,
        "body": h.recipe,
        "ball_joints": h.ball_joints,
        "nq": model.nq,
        "nv": model.nv,
        "joint_names": list(model.names),
        "contacts": {c.side: [k.name for k in c.constraints] or c.spec.kind for c in sim.contacts},
        "feet": list(h.feet),
        "dt": scene.dt,
        "record_rate": scene.record_rate,
        "scene": scene.to_dict(),
        "events": sim.book.events,
        "violations": sim.book.violations,
        "counters": sim.counters,
        "steps": steps,
        "wall_time": wall,
        "max_residual": float(np.nanmax(rec.residual[: rec.n], initial=0.0)),
        "max_velocity_residual": rec.velocity_residual,
        "quaternion_drift": norm_drift,
    }
    ground = sim.plant.ground
    if ground is not None:
        meta["max_penetration"] = ground.max_penetration
        meta["contact_solver_failures"] = ground.solver.failures
        meta["contact_solver_fallbacks"] = ground.solver.fallbacks
    return meta | sim.setup.integrator.metadata()


def scene_schedule(sim: Simulation, k: int, t: float, q, v, last: StepResult | None):
    """The scene's contact schedule: windows, touchdowns and the force checks
    (:meth:`~.contacts.ContactBook.update_contacts`)."""
    return sim.update_contacts(t, q, v, last)


def check_divergence(t: float, q, v) -> None:
    """Raise DivergenceError if the state is non-finite or exploding at time t."""
    # the common case in two reductions: a NaN or inf anywhere makes a sum non-finite (and
    # fails the comparison); |v| <= MAX_SPEED everywhere when v.v <= MAX_SPEED^2
    if math.isfinite(q.sum()) and float(v @ v) <= MAX_SPEED * MAX_SPEED:
        return
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise DivergenceError(f"the state became non-finite at t = {t:.6f} s")
    speed = float(np.abs(v).max())
    if speed > MAX_SPEED:
        raise DivergenceError(
            f"the state is exploding at t = {t:.6f} s (|v| = {speed:.3g} > {MAX_SPEED:g}): "
            "reduce the time step or the gains"
        )


def simulate(scene: Scene, humanoid: Humanoid | None = None, quiet: bool = False) -> Trajectory:
    """Run a scene. Returns the trajectory, also when the run stopped early: see its status."""
    return Simulation(scene, humanoid).run(quiet=quiet)
