"""The run loop: a :class:`Scene` in, a :class:`Trajectory` out. Every simulation, the walk
included, is stepped by :meth:`Simulation.run`.

What a run does is plugged into the one loop: effects (pushes, damping, springs) and a
controller (the posture hold, the walking controller) give torques; a contact schedule says when
contacts attach and release (the scene's windows and touchdowns by default; a footstep plan for
the walk); monitors observe every step (the walk's checks) and may stop the run.

One step: effects -> tau; bias b(q, v) as far as the scene needs it (no gravity term without
gravity, nothing velocity-dependent without Coriolis terms); plain ABA when no contact is
attached, else the KKT solve of :mod:`humanoid.constraints`; then the integrator. After each
step: optional projection on the constraint manifold, contact checks (unilaterality, friction,
centre of pressure) that release unilateral contacts, touchdown that attaches them again with an
impulse, and the divergence guard. Records are taken at ``record_rate`` into preallocated
arrays, so memory is fixed by the duration and a run does not slow down as it goes.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pinocchio as pin

from .constraints import Baumgarte, JointLock, solve_kkt, update_kinematics
from .constraints.ground import ContactSolver, Ground, GroundSettings
from .constraints.limits import JointRanges
from .constraints.native import NativeSolution, NativeSolve
from .constraints.quaternion import CoordinateMap, QuaternionNorm
from .constraints.solve import impact, stack
from .contacts import ContactState
from .effects import (
    JointDamping,
    JointLimits,
    JointSprings,
    PostureController,
    Push,
    joint_mask,
)
from .errors import DivergenceError, HumanoidError, SceneError
from .integrators import STEPPERS, CoordinateSpace, DormandPrince, LieGroupSpace
from .linalg import cholesky_lapack, one_thread
from .model import Humanoid
from .scene import Contact, Scene, load_body
from .trajectory import Progress, Recorder, Trajectory

__all__ = ["ContactState", "Simulation", "StepResult", "Trajectory", "simulate"]


MAX_SPEED = 1e4  # [m/s or rad/s] beyond this the state counts as diverged
GIMBAL_TOLERANCE = 1e-3  # |cos(middle angle)| below this: a hinge triplet is at gimbal lock
GROUND_TOLERANCE = 1e-6  # [m] a sole point this close to z = 0 touches the ground
# ABA's world-frame variant: the same accelerations (to 1e-12), 10 % faster on the bodies here
# (the contact-free path of a scene with nothing else; elsewhere the local one, whose
# round-off the ground scenes' resting states were checked with)
_WORLD = pin.Convention.WORLD


class StepResult:
    """One step of :meth:`Simulation.step` (read-only by convention: a plain slotted class,
    built every step, costs a quarter of a frozen dataclass).

    Attributes:
        t: Time at the end of the step [s].
        q, v: The state at the end of the step ((x, x') in the coordinate formulation).
        torque: The joint torques at the start of the step (what the records call tau).
        solution: The constrained solve at the start of the step (its accelerations and
            contact forces), or None when no contact was attached.
    """

    __slots__ = ("t", "q", "v", "torque", "solution")

    def __init__(self, t: float, q: np.ndarray, v: np.ndarray, torque: np.ndarray,
                 solution: object | None) -> None:  # fmt: skip
        self.t, self.q, self.v, self.torque, self.solution = t, q, v, torque, solution


class Simulation:
    """A scene made ready to run: model, effects, contacts, integrator.

    Plug-ins (see the module docstring): ``controller`` (an Effect with an optional
    ``before_step``), ``schedule`` (a callable ``(sim, k, t, q, v, last_step) -> v``, the
    scene's contact windows and touchdowns by default) and ``monitors`` (objects with
    ``observe(sim, k, t, q, v, step)``, called after every step; raising
    :class:`~humanoid.errors.RunFailed` stops the run as failed).
    """

    def __init__(self, scene: Scene, humanoid: Humanoid | None = None) -> None:
        self.scene = scene
        self.h = humanoid or load_body(scene)
        h = self.h
        self.model = h.model.copy()
        self.gravity = np.array(scene.effects.gravity, dtype=float)
        self.has_gravity = bool(np.any(self.gravity))
        self.model.gravity = pin.Motion(self.gravity, np.zeros(3))
        self.data = self.model.createData()
        self.mask = joint_mask(self.model)
        q0, v0 = scene.check(h)  # frames, sizes, finite numbers; the initial state
        self.q0, self.v0 = q0, v0
        e = scene.effects
        self.effects = []
        if e.damping > 0:
            self.effects.append(JointDamping(self.model, e.damping))
        if e.springs > 0:
            self.effects.append(JointSprings(self.model, e.springs, q0))
        if e.joint_limits is not None and e.joint_limits.kind == "spring":
            self.effects.append(JointLimits(h, e.joint_limits.stiffness, e.joint_limits.damping))
        for p in e.pushes:
            self.effects.append(
                Push(self.model.getFrameId(p.frame), p.force, p.start, p.duration, p.torque)
            )
        self.contacts = [ContactState(h, c) for c in e.contacts]
        self.ground = None  # the velocity-level contact solve (ground, constraint ranges)
        self.ground_step = None  # what it found in the last step
        self.max_penetration = 0.0  # [m] deepest ground point at the start of any step
        self.ranges = None
        if e.ground is not None:
            self.ground = self._ground_solver(e)
        self.controller = None
        self.schedule = scene_schedule
        self.monitors: list = []
        if scene.controller.kind == "posture":
            ctl = scene.controller
            J = self._initial_contact_jacobian(q0)
            self.controller = PostureController(
                self.model, q0, ctl.kp, ctl.kd, ctl.frequency, ctl.damping_ratio, J
            )
        tc = scene.stabilisation.baumgarte * scene.dt
        self.baumgarte = Baumgarte.from_time_constant(tc) if tc > 0 else Baumgarte()
        self.coordinates = scene.stabilisation.quaternions == "coordinates"
        if self.coordinates:
            self.cmap = CoordinateMap(self.model)
            self.norm = QuaternionNorm(self.cmap)
            self.space = CoordinateSpace(self.model.nq)
        else:
            self.space = LieGroupSpace(self.model)
        self.adaptive = DormandPrince(scene.rtol, scene.atol, max_step=scene.dt) if (
            scene.integrator == "adaptive"
        ) else None  # fmt: skip
        self.step_fn = STEPPERS.get(scene.integrator)
        self.velocity_terms = e.coriolis
        self.counters = {"aba": 0, "kkt": 0, "bias": 0, "gravity": 0}
        self.events: list[dict] = []
        self.violations: dict[str, int] = {}
        self.last = None  # the last solve (stage 1 of the last step)
        self._active = None
        self._tick = 0.0
        self._zero = np.zeros(self.model.nv)
        self._zero.flags.writeable = False
        self.joint_torque = self._zero
        self._solve = None  # the native backend's prepared active set
        self._implicit = None  # (controller, effects) -> the ground step's implicit terms
        self._eye = np.eye(self.model.nv)
        # the native backend needs the full bias b(q, v) (Pinocchio's); a scene without the
        # velocity terms is solved by the reference
        self._native_backend = scene.stabilisation.backend == "native" and e.coriolis
        self._native_backend &= scene.stabilisation.quaternions == "lie"
        self._dynamics = self.coordinate_acceleration if self.coordinates else self.acceleration
        # semi-implicit Euler on the Lie group without the ground's velocity-level solve: one
        # evaluation per step, inlined in :meth:`step`
        self._euler = (scene.integrator == "semi_implicit_euler" and not self.coordinates
                       and self.ground is None)  # fmt: skip
        # a fixed-step scheme on the Lie group with no contact ever and all velocity terms:
        # ABA alone, while no effect or controller is plugged in (checked at each step)
        self._free = (self.step_fn is not None and not self.coordinates and not self.contacts
                      and self.ground is None and self.velocity_terms)  # fmt: skip
        self.gimbal = _gimbal_monitor(h)
        self._locked: set[str] = set()

    @property
    def n_steps(self) -> int:
        """How many steps of dt the scene's duration takes (at least one)."""
        return max(1, int(round(self.scene.duration / self.scene.dt)))

    def _ground_solver(self, e) -> ContactSolver:
        """The ground contact of the bodies the scene names, and the joint ranges as
        constraints if it asks for them."""
        h, spec = self.h, e.ground
        geometry = h.collision_model if h.collision_model.ngeoms else h.visual_model
        if isinstance(spec.bodies, str):
            if spec.bodies == "all":
                chosen = range(geometry.ngeoms)
            else:
                # a foot and what hangs below it (its toes)
                model = self.model
                roots = [model.frames[h.frame_id(f)].parentJoint for f in h.feet]
                feet = {j for root in roots for j in model.subtrees[root]}
                chosen = [i for i, g in enumerate(geometry.geometryObjects)
                          if g.parentJoint in feet]  # fmt: skip
        else:
            joints = {}
            for name in spec.bodies:
                if not self.model.existFrame(name):
                    links = sorted(f.name for f in self.model.frames
                                   if f.type == pin.FrameType.BODY)  # fmt: skip
                    raise SceneError(f"{self.scene.source}: effects.ground.bodies: no link "
                                     f"{name!r}; links: {', '.join(links)}")  # fmt: skip
                joints[self.model.frames[self.model.getFrameId(name)].parentJoint] = name
            chosen = [i for i, g in enumerate(geometry.geometryObjects) if g.parentJoint in joints]
        settings = GroundSettings(mu=spec.mu, margin=spec.margin, tolerance=spec.tolerance)
        ground = Ground(self.model, geometry, list(chosen), settings) if chosen else None
        limits = e.joint_limits
        if limits is not None and limits.kind == "constraint":
            self.ranges = JointRanges(h)
        return ContactSolver(self.model, ground, self.ranges, settings)

    def legs(self) -> dict:
        """Each side's leg: the joints from its hip down to its sole (the subtree of the root's
        child on the way to the sole), or {} for a body without two soles."""
        model, out = self.model, {}
        for side in ("left", "right"):
            try:
                j = model.frames[self.h.sole_id(side)].parentJoint
            except HumanoidError:
                return {}
            while j > 0 and model.parents[j] > 1:
                j = model.parents[j]
            if j <= 1:
                return {}
            out[side] = np.array(model.subtrees[j], dtype=int)
        return out

    def ground_step_advance(self, t: float, q, v, dt: float):
        """One velocity-level step: v_free = v + dt a(q, v) without contacts, the contact
        impulses of the ground and of the joint ranges, v+ = v_free + M^-1 J^T lambda,
        q+ = q (+) dt v+ (semi-implicit Euler with impulses)."""
        model, data = self.model, self.data
        implicit = self._implicit_terms()
        if implicit is None:
            v_free = v + dt * self.acceleration(t, q, v)
            pin.computeJointJacobians(model, data, q)
            Minv = pin.computeMinverse(model, data, q)
        else:
            K, D = implicit
            tau = self.applied(t, q, v)
            Mt = pin.crba(model, data, q) + dt * D + (dt * dt) * K
            potrf, potrs = cholesky_lapack()
            factor, info = potrf(Mt, lower=True)
            if info:
                raise DivergenceError(f"the mass matrix with the implicit gains is not "
                                      f"positive definite at t = {t:.6f} s")  # fmt: skip
            Minv = potrs(factor, self._eye, lower=True)[0]
            v_free = v + dt * (Minv @ (tau - self.bias(q, v) - dt * (K @ v)))
            self.counters["implicit"] = self.counters.get("implicit", 0) + 1
            pin.computeJointJacobians(model, data, q)
        v_new, found = self.ground.step(q, v_free, dt, Minv, data)
        if implicit is not None:  # the torque the joints applied over the step
            self.joint_torque = self.joint_torque - (dt * (K @ v_new) + D @ (v_new - v))
            self.last = (self.joint_torque, None)
        self.counters["contact_solves"] = self.counters.get("contact_solves", 0) + 1
        if len(found.phi):
            self.max_penetration = max(self.max_penetration, float(-found.phi.min()))
        self.ground_step = found
        return pin.integrate(model, q, dt * v_new), v_new

    def _implicit_terms(self):
        """(K, D): the stiffness and damping of the controller and effects that say they are
        linear spring-dampers (:meth:`Effect.implicit`: the posture hold), taken implicitly by
        the ground contact's step, or None if there are none.

        A posture hold tuned on the body standing on its feet is far too stiff for a foot
        alone: when a foot rocks onto its toes, the ankle's gain meets the foot's own inertia,
        a mode of a few kHz that an explicit step of 1 ms cannot follow (a 100 N push at the
        thorax of the balance scene exploded within 40 ms). Taken implicitly,
        (M + dt D + dt^2 K) v+ = M v + dt (tau - b - dt K v) + J^T lambda, every such mode is
        damped at any step. (Cached per controller: a run may plug in its own.)"""
        key = (self.controller, len(self.effects))
        if self._implicit is not None and self._implicit[0] == key:
            return self._implicit[1]
        nv = self.model.nv
        K, D, any_terms = np.zeros((nv, nv)), np.zeros((nv, nv)), False
        for eff in [self.controller, *self.effects]:
            terms = eff.implicit(nv) if eff is not None else None
            if terms is not None:
                K, D, any_terms = K + terms[0], D + terms[1], True
        self._implicit = (key, (K, D) if any_terms else None)
        return self._implicit[1]

    def _initial_contact_jacobian(self, q0) -> np.ndarray:
        """Jacobian at q0 of the contacts that attach at t = 0 (scheduled, on the ground).
        On the ground contact (no scheduled contacts), the feet standing on the floor count
        as welded."""
        self.kinematics(q0)
        contacts = self.contacts
        if not contacts and self.ground is not None:
            contacts = [ContactState(self.h, Contact(side)) for side in ("left", "right")]
        rows = []
        for c in contacts:
            if c.spec.start == 0.0 and c.lowest(self.data) <= GROUND_TOLERANCE:
                c.attach(self.data)
                # the feet's own rows (a weld's locked toes) left out: the hold's gains see the
                # toes free to turn (with them, its toes' gain was the pseudo-inverse of a
                # near-zero inertia, and the pushed balance scene's toes chattered at 34 rad/s)
                rows += [k.jacobian(self.model, self.data) for k in c.constraints
                         if not isinstance(k, JointLock)]  # fmt: skip
                c.release()
                self._active = None
                c.ever_attached = False
        return np.vstack(rows) if rows else np.zeros((0, self.model.nv))

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

    def active_constraints(self):
        """The constraints of the attached contacts (cached; refreshed on attach/release)."""
        if self._active is None:
            self._active = [c for s in self.contacts if s.attached for c in s.constraints]
        return self._active

    # -- dynamics ------------------------------------------------------------------------
    def acceleration(self, t, q, v) -> np.ndarray:
        """dv/dt for the Lie-group formulation."""
        if self.effects or self.controller is not None:
            tau = self.applied(t, q, v)
        else:
            tau = self.joint_torque = self._zero
        constraints = self._active
        if constraints is None:
            constraints = self.active_constraints()
        if not constraints:
            self.counters["aba"] += 1
            self.last = (self.joint_torque, None)
            # a new array (Pinocchio's bindings copy data.ddq out)
            return pin.aba(self.model, self.data, q, v if self.velocity_terms else self._zero, tau)
        self.counters["kkt"] += 1
        if self._native_backend:
            return self._native(q, v, tau, constraints)
        update_kinematics(self.model, self.data, q, v)
        Minv = pin.computeMinverse(self.model, self.data, q)
        J, gamma = stack(self.model, self.data, constraints, v, self.baumgarte)
        sol = solve_kkt(Minv, tau - self.bias(q, v), J, gamma)
        self.last = (self.joint_torque, sol)
        return sol.a

    def _aba(self, t, q, v) -> np.ndarray:
        """dv/dt of a scene without contacts, effects or controller: ABA (a new array)."""
        self.counters["aba"] += 1
        return pin.aba(self.model, self.data, q, v, self._zero, _WORLD)

    def _native(self, q, v, tau, constraints):
        """The native backend: the active set solved in Pinocchio's C++ (prepared once per
        active set: :class:`~humanoid.constraints.native.NativeSolve`)."""
        solve = self._solve
        if solve is None or solve.source is not constraints:
            redundant = sum(c.size for c in constraints) > 6 * len(self.contacts)
            solve = self._solve = NativeSolve(self.model, constraints, self.baumgarte, redundant)
        a = solve.acceleration(q, v, tau)
        self.last = (self.joint_torque, NativeSolution(solve))
        return a

    def coordinate_acceleration(self, t, x, xdot) -> np.ndarray:
        """d(x')/dt for the seeds' coordinate formulation (quaternion norm as a constraint)."""
        cm = self.cmap
        q = cm.configuration(x)
        H = cm.H(x)
        v = H @ xdot
        tau = self.applied(t, q, v)
        update_kinematics(self.model, self.data, q, v)
        pin.crba(self.model, self.data, q)
        M = self.data.M.copy()
        b = self.bias(q, v)
        Mx = H.T @ M @ H
        fx = H.T @ (tau - b - M @ cm.Hdot_xdot(x, xdot))
        constraints = self.active_constraints()
        Jc_v, gc = stack(self.model, self.data, constraints, v, Baumgarte())
        gc = gc - Jc_v @ cm.Hdot_xdot(x, xdot)
        Jc = Jc_v @ H
        Jn, gn = self.norm.jacobian(x), -self.norm.drift(xdot)
        bg = self.baumgarte
        if bg.active:
            gn -= 2 * bg.alpha * (Jn @ xdot) + bg.beta**2 * self.norm.residual(x)
            if constraints:
                gc -= 2 * bg.alpha * (Jc @ xdot) + bg.beta**2 * np.concatenate(
                    [c.residual(self.model, self.data) for c in constraints]
                )
        J = np.vstack([Jn, Jc])
        gamma = np.concatenate([gn, gc])
        m = J.shape[0]
        K = np.block([[Mx, J.T], [J, np.zeros((m, m))]])
        rhs = np.concatenate([fx, gamma])
        try:
            sol = np.linalg.solve(K, rhs)
        except np.linalg.LinAlgError:
            sol = None
        if sol is None or not np.all(np.isfinite(sol)):  # redundant rows: least squares
            sol = np.linalg.lstsq(K, rhs, rcond=1e-13)[0]
        self.counters["kkt"] += 1
        self.last = (self.joint_torque, None)
        if constraints:
            from .constraints.solve import ConstrainedAcceleration

            lam = -sol[cm.nq + self.norm.size :]
            a = H @ sol[: cm.nq] + cm.Hdot_xdot(x, xdot)
            self.last = (self.joint_torque, ConstrainedAcceleration(a, lam, 0.0, m, "coordinates"))
        return sol[: cm.nq]

    # -- one step ------------------------------------------------------------------------
    def step(self, t: float, q, v, dt: float) -> StepResult:
        """Advance (q, v) (or (x, x') in the coordinate formulation) by dt."""
        self._tick = t
        # nothing but ABA (no contact ever, no effect or controller plugged in): called directly
        aba_only = self._free and not self.effects and self.controller is None
        if self._euler:  # semi-implicit Euler on the Lie group, inlined (the hot path)
            if aba_only:
                a = self._aba(t, q, v)
                self.last = (self._zero, None)
            else:
                a = self.acceleration(t, q, v)
            torque, solution = self.last
            v_new = v + dt * a
            return StepResult(t + dt, pin.integrate(self.model, q, dt * v_new), v_new, torque,
                              solution)  # fmt: skip
        self._first = None
        self._frozen = False
        if self.ground is not None:
            q_new, v_new = self.ground_step_advance(t, q, v, dt)
            self._first = self.last
        elif aba_only:
            q_new, v_new = self.step_fn(self.space, self._aba, t, q, v, dt)
            self.last = self._first = (self._zero, None)
        elif self.adaptive is not None:
            q_new, v_new = self.adaptive.advance(self.space, self._capture, t, q, v, t + dt)
        else:
            q_new, v_new = self.step_fn(self.space, self._capture, t, q, v, dt)
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

    # -- contacts ------------------------------------------------------------------------
    def kinematics(self, q, v=None) -> None:
        """Placements, velocities, Jacobians of ``self.data`` at (q, v) (v = 0 if not given)."""
        v = np.zeros(self.model.nv) if v is None else v
        update_kinematics(self.model, self.data, q, v)

    def attach(self, contacts, t: float, q, v, reason: str):
        """Attach contacts where the feet are, with the one impulse that stops them.

        The impulse dv = M^-1 J^T Lambda makes J v+ = 0 for every active constraint (an
        inelastic impact), so the velocity is consistent with the new constraint set.
        """
        self.kinematics(q, v)
        for contact in contacts:
            speed = max(0.0, -min(
                pin.getFrameVelocity(self.model, self.data, p, pin.LOCAL_WORLD_ALIGNED).linear[2]
                for p in contact.points
            ))  # fmt: skip
            contact.attach(self.data)
            self.events.append(
                {"t": t, "contact": contact.side, "event": "attach", "reason": reason,
                 "impact_speed": float(speed)}
            )  # fmt: skip
        self._active = None
        J, _ = stack(self.model, self.data, self.active_constraints(), v, Baumgarte())
        Minv = pin.computeMinverse(self.model, self.data, q)
        return impact(Minv, J, v)

    def store_forces(self, solution) -> None:
        """Give each attached contact its forces from a constrained solve, as wrenches at the
        kinematics in ``self.data`` (:meth:`kinematics` first)."""
        split = solution.split(self.active_constraints())
        for c in self.contacts:
            if c.attached:
                c.store(self.model, self.data,
                        np.concatenate([split[k.name] for k in c.constraints]))  # fmt: skip

    def release(self, contact, t: float, reason: str) -> None:
        """Release a contact (lift-off, end of its window, a violated check) and log it."""
        contact.release()
        self._active = None
        self.events.append({"t": t, "contact": contact.side, "event": "release",
                            "reason": reason})  # fmt: skip

    def switch_contacts(self, t: float, q, v, stance):
        """Follow a contact schedule: release the attached contacts whose side is not in
        ``stance`` (lift-off), attach the others in it where they are, with the impulse that
        stops them (:meth:`attach`). Returns v after the impulse (v itself if none landed)."""
        landing = []
        for c in self.contacts:
            if c.attached and c.side not in stance:
                self.release(c, t, "lift-off")
            elif not c.attached and c.side in stance:
                landing.append(c)
        return self.attach(landing, t, q, v, "touchdown") if landing else v

    def project(self, q, v):
        """Put q and v back on the manifold of the active constraints (Gauss-Newton, 3 its)."""
        constraints = self.active_constraints()
        if not constraints:
            return q, v
        for _ in range(3):
            self.kinematics(q, v)
            e = np.concatenate([c.residual(self.model, self.data) for c in constraints])
            if np.abs(e).max() < 1e-12:
                break
            Je = np.vstack([c.residual_jacobian(self.model, self.data) for c in constraints])
            Minv = pin.computeMinverse(self.model, self.data, q)
            q = pin.integrate(self.model, q, solve_kkt(Minv, np.zeros(self.model.nv), Je, -e).a)
        self.kinematics(q, v)
        J, _ = stack(self.model, self.data, constraints, v, Baumgarte())
        Minv = pin.computeMinverse(self.model, self.data, q)
        return q, impact(Minv, J, v)

    def watch_gimbal_lock(self, t: float, q) -> None:
        """Report hinge triplets (Euler mode) whose middle angle is at +-90 deg (gimbal lock):
        there the triplet loses a degree of freedom and M becomes singular."""
        for name, iq in self.gimbal:
            locked = abs(math.cos(q[iq])) < GIMBAL_TOLERANCE
            if locked and name not in self._locked:
                self._locked.add(name)
                self.events.append(
                    {"t": t, "contact": "", "event": "gimbal_lock", "joint": name,
                     "reason": f"middle angle {q[iq]:.6f} rad: the hinge triplet {name} is "
                     "singular here (use ball_joints='quaternion')"}
                )  # fmt: skip
            elif not locked:
                self._locked.discard(name)

    def update_contacts(self, t: float, q, v, last: StepResult | None = None):
        """The scene's contact schedule: store and check the forces of the ``last`` step;
        release, attach on schedule or at touchdown. Returns v (after any impulse)."""
        if not self.contacts:
            return v
        sol = last.solution if last is not None else None
        if sol is not None and self.active_constraints():
            self.kinematics(q, v)
            self.store_forces(sol)
        for c in self.contacts:
            if c.attached:
                problems = c.check(self.data) if sol is not None else []
                if problems:
                    self.violations[c.side] = self.violations.get(c.side, 0) + 1
                if t >= c.spec.end or (problems and c.spec.unilateral):
                    why = "end of window" if t >= c.spec.end else "; ".join(problems)
                    self.release(c, t, why)
        landing = {"scheduled": [], "touchdown": []}
        for c in self.contacts:
            if not c.attached and c.spec.start <= t < c.spec.end:
                self.kinematics(q, v)
                height = c.lowest(self.data)
                if not c.ever_attached and height <= GROUND_TOLERANCE:
                    landing[
                        "scheduled" if t < c.spec.start + self.scene.dt / 2 else "touchdown"
                    ].append(c)
                elif height <= 0.0 and c.sinking(self.model, self.data):
                    landing["touchdown"].append(c)
        for reason, contacts in landing.items():
            if contacts:
                v = self.attach(contacts, t, q, v, reason)
        return v

    # -- the loop ------------------------------------------------------------------------
    def run(self, quiet: bool = False) -> Trajectory:
        """Simulate the scene: every tick, the contact schedule, the controller's update, one
        step, the record, the monitors, the divergence guard, the optional projection.

        Stops early, keeping what was computed, on Ctrl-C (status ``interrupted``), on
        divergence (``diverged``: non-finite or exploding state, an adaptive step that will
        not converge) and on any other :class:`~humanoid.errors.HumanoidError` raised inside
        the loop (``failed``: a fall seen by a monitor, a controller without a solution).

        The run's dense algebra (BLAS, LAPACK, OpenMP) uses one thread whatever the
        environment says (:func:`~humanoid.linalg.one_thread`); runs in parallel get their
        threads from a study's workers.
        """
        with one_thread():
            return self._run(quiet)

    def _run(self, quiet: bool) -> Trajectory:
        scene, model = self.scene, self.model
        dt = scene.dt
        n_steps = self.n_steps
        every = max(1, int(round(1.0 / (scene.record_rate * dt))))
        rec = Recorder(n_steps // every + 1, model, self.contacts, self.ground is not None,
                       self.legs())  # fmt: skip
        t, q, v = 0.0, self.q0.copy(), self.v0.copy()
        x, xd = self.cmap.from_tangent(q, v) if self.coordinates else (q, v)
        status, message = "completed", ""
        start = time.perf_counter()
        progress = Progress(n_steps, quiet)
        norm_drift = 0.0  # largest | |Q|^2 - 1 | of the coordinate formulation's raw state
        before_step = getattr(self.controller, "before_step", None)
        last = None
        k = 0
        try:
            for k in range(n_steps):
                t = k * dt
                x, xd, q, v = self._schedule_contacts(k, t, x, xd, q, v, last)
                if before_step is not None:
                    before_step(self, k, t, q, v)
                last = self.step(t, x, xd, dt)
                if k % every == 0:
                    rec.add(self, t, q, v, last)
                for monitor in self.monitors:
                    monitor.observe(self, k, t, q, v, last)
                check_divergence(last.t, last.q, last.v)
                x, xd = last.q, last.v
                if self.coordinates:
                    norm_drift = max(norm_drift, float(np.abs(self.norm.residual(x)).max()))
                    if scene.stabilisation.projection:
                        x = self.cmap.configuration(x)
                        q, v = self.project(x, self.cmap.H(x) @ xd)
                        x, xd = self.cmap.from_tangent(q, v)
                    q, v = self.cmap.configuration(x), self.cmap.H(x) @ xd
                else:
                    if scene.stabilisation.projection:
                        x, xd = self.project(x, xd)
                    q, v = x, xd
                if self.gimbal:
                    self.watch_gimbal_lock(last.t, q)
                progress.update(k + 1)
            t = n_steps * dt
            x, xd, q, v = self._schedule_contacts(n_steps, t, x, xd, q, v, last)
            rec.add(self, t, q, v, self.evaluate(t, x, xd))
        except KeyboardInterrupt:
            status, message = "interrupted", f"interrupted by the user at t = {t:.4f} s"
        except DivergenceError as exc:
            status, message = "diverged", str(exc)
        except HumanoidError as exc:
            status, message = "failed", str(exc)
        finally:
            progress.close()
        wall = time.perf_counter() - start
        meta = {
            "status": status,
            "message": message,
            "model": self.h.source,
            "body": self.h.recipe,
            "ball_joints": self.h.ball_joints,
            "nq": model.nq,
            "nv": model.nv,
            "joint_names": list(model.names),
            "contacts": {
                c.side: [k.name for k in c.constraints] or c.spec.kind for c in self.contacts
            },
            "feet": list(self.h.feet),
            "dt": dt,
            "record_rate": scene.record_rate,
            "scene": scene.to_dict(),
            "events": self.events,
            "violations": self.violations,
            "counters": self.counters,
            "steps": k + 1 if status == "completed" else k,
            "wall_time": wall,
            "max_residual": float(np.nanmax(rec.residual[: rec.n], initial=0.0)),
            "max_velocity_residual": rec.velocity_residual,
            "quaternion_drift": norm_drift,
        }
        if self.ground is not None:
            meta["max_penetration"] = self.max_penetration
            meta["contact_solver_failures"] = self.ground.failures
        if self.adaptive is not None:
            meta["adaptive"] = vars(self.adaptive.stats)
        return rec.trajectory(meta)

    def _schedule_contacts(self, k, t, x, xd, q, v, last):
        """The contact schedule at tick k; the formulation's state follows an impulse."""
        v_new = self.schedule(self, k, t, q, v, last)
        if v_new is v:
            return x, xd, q, v
        x, xd = self.cmap.from_tangent(q, v_new) if self.coordinates else (q, v_new)
        return x, xd, q, v_new


def scene_schedule(sim: Simulation, k: int, t: float, q, v, last: StepResult | None):
    """The scene's contact schedule: windows, touchdowns and the force checks
    (:meth:`Simulation.update_contacts`)."""
    return sim.update_contacts(t, q, v, last)


def _gimbal_monitor(h: Humanoid) -> list[tuple[str, int]]:
    """(name, q index of the middle hinge) of every hinge triplet of an Euler-mode model."""
    if h.ball_joints != "euler":
        return []
    from .fusion import ball_name, find_triplets

    model = h.model
    return [
        (ball_name(model, t), model.joints[t[1]].idx_q)
        for t in find_triplets(model, (h.visual_model, h.collision_model))
    ]


def check_divergence(t: float, q, v) -> None:
    """Raise DivergenceError if the state is non-finite or exploding at time t."""
    # the common case in two reductions: a NaN or inf anywhere makes a sum or max non-finite
    # (and fails the comparison)
    if math.isfinite(q.sum()) and float(np.abs(v).max()) <= MAX_SPEED:
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
