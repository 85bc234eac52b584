"""The contacts' bookkeeping during a run: which are attached, when they attach (with the
impulse that stops them) and release, the checks of their forces, the projection on their
constraints, and the log of these events."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..constraints import Baumgarte, solve_kkt, update_kinematics
from ..constraints.solve import impact, stack
from .setup import GROUND_TOLERANCE, Setup

__all__ = ["GIMBAL_TOLERANCE", "ContactBook"]

GIMBAL_TOLERANCE = 1e-3  # |cos(middle angle)| below this: a hinge triplet is at gimbal lock


class ContactBook:
    """The attached contacts of a run and what happened to them (``events``, ``violations``).

    Works on the set-up's model, data and :class:`~humanoid.contacts.ContactState` list.
    """

    def __init__(self, setup: Setup) -> None:
        self.model, self.data = setup.model, setup.data
        self.contacts = setup.contacts
        self.dt = setup.scene.dt
        self.gimbal = setup.gimbal
        self.events: list[dict] = []
        self.violations: dict[str, int] = {}
        self._active = None
        self._locked: set[str] = set()

    def kinematics(self, q, v=None) -> None:
        """Placements, velocities, Jacobians of ``self.data`` at (q, v) (v = 0 if not given)."""
        v = np.zeros(self.model.nv) if v is None else v
        update_kinematics(self.model, self.data, q, v)

    def active_constraints(self):
        """The constraints of the attached contacts (cached; refreshed on attach/release)."""
        if self._active is None:
            self._active = [c for s in self.contacts if s.attached for c in s.constraints]
        return self._active

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

    def update_contacts(self, t: float, q, v, last=None):
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
        landing: dict[str, list] = {"scheduled": [], "touchdown": []}
        for c in self.contacts:
            if not c.attached and c.spec.start <= t < c.spec.end:
                self.kinematics(q, v)
                height = c.lowest(self.data)
                if not c.ever_attached and height <= GROUND_TOLERANCE:
                    on_time = t < c.spec.start + self.dt / 2
                    landing["scheduled" if on_time else "touchdown"].append(c)
                elif height <= 0.0 and c.sinking(self.model, self.data):
                    landing["touchdown"].append(c)
        for reason, contacts in landing.items():
            if contacts:
                v = self.attach(contacts, t, q, v, reason)
        return v

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
