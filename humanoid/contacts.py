"""A foot's contact during a run: its constraints (a weld or four point contacts), whether it
is attached, its last forces, and the checks of unilaterality, friction and centre of pressure.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from .constraints import JointLock, PointContact, Weld, foot_hinges
from .model import Humanoid

__all__ = ["CONTACT_CONSTRAINTS", "ContactState", "cop_in_sole", "cop_on_plane"]


def cop_on_plane(wrench, origin) -> np.ndarray:
    """The centre of pressure of a wrench (force, moment about ``origin``; world axes): where
    its line of action meets the horizontal plane through ``origin``, a world point."""
    f, tau = wrench[:3], wrench[3:6]
    return np.array([origin[0] - tau[1] / f[2], origin[1] + tau[0] / f[2], origin[2]])


def cop_in_sole(wrench, rotation) -> np.ndarray:
    """The centre of pressure of a wrench about a sole's origin (world axes) in the sole's
    own axes, relative to its origin: (x, y) on the sole's plane."""
    local_tau, local_f = rotation.T @ wrench[3:6], rotation.T @ wrench[:3]
    return np.array([-local_tau[1], local_tau[0]]) / local_f[2]


class ContactState:
    """One foot's contact: its constraints, whether it is attached, and its last forces."""

    def __init__(self, h: Humanoid, spec) -> None:
        self.spec = spec
        self.side = spec.foot
        self.sole = h.sole_id(spec.foot)
        self.points = [h.frame_id(n) for n in h.require_contact_points(self.side)]
        # a welded foot's own hinges (the toes') are locked with it
        self.model = h.model
        self.hinges = foot_hinges(h.model, self.sole, self.points)
        self.attached = False
        self.ever_attached = False
        self.constraints: list = []  # its kind's constraints (a weld's first)
        self.wrench = np.full(6, np.nan)
        self.point_forces = np.full((4, 3), np.nan)
        self.lock_torques = np.zeros(len(self.hinges))  # [N m] on the locked hinges
        # sole rectangle in the sole frame, for the centre-of-pressure check
        lo, hi = h.sole_box(self.side)
        self.cop_box = lo[:2], hi[:2]
        self._cop_limits = (*lo[:2].tolist(), *hi[:2].tolist())  # (x, y low, x, y high)

    def attach(self, data: pin.Data) -> None:
        """Attach where the foot is in ``data`` (its placements), with its kind's constraints
        (:data:`CONTACT_CONSTRAINTS`)."""
        self.constraints = CONTACT_CONSTRAINTS[self.spec.kind](self, data)
        self.attached = self.ever_attached = True

    def release(self) -> None:
        self.constraints = []
        self.attached = False
        self.wrench[:] = np.nan
        self.point_forces[:] = np.nan
        self.lock_torques[:] = 0.0

    def store(self, model, data, forces: np.ndarray) -> None:
        """World-axes wrench about the sole origin (and point forces) from the solve's lambda."""
        o = data.oMf[self.sole].translation
        if self.spec.kind == "weld":  # the hinges' locks are internal
            self.wrench = self.constraints[0].wrench_world(model, data, forces[:6])
            self.lock_torques = np.array(forces[6:], dtype=float)
        else:
            f = forces.reshape(4, 3)
            self.point_forces = f
            arms = np.array([data.oMf[p].translation - o for p in self.points])
            self.wrench = np.concatenate([f.sum(axis=0), np.cross(arms, f).sum(axis=0)])

    def check(self, data) -> list[str]:
        """Violations of unilaterality, friction and the centre of pressure (in Python floats:
        a welded stance checks both feet every step)."""
        out = []
        mu = self.spec.mu
        weld = self.spec.kind == "weld"
        loads = [self.wrench[:3].tolist()] if weld else self.point_forces.tolist()
        lowest = min(f[2] for f in loads)
        if lowest < 0:
            out.append(f"normal force {lowest:.1f} N < 0")
        for fx, fy, fz in loads:
            if fz > 0 and math.hypot(fx, fy) > mu * fz * (1 + 1e-9) + 1e-9:
                out.append(f"friction |f_t| {math.hypot(fx, fy):.1f} N > mu f_n")
                break
        if weld and self.wrench[2] > 1e-9:
            cop = cop_in_sole(self.wrench, data.oMf[self.sole].rotation)
            (x, y), (lx, ly, hx, hy) = cop.tolist(), self._cop_limits
            if x < lx - 1e-9 or y < ly - 1e-9 or x > hx + 1e-9 or y > hy + 1e-9:
                out.append(f"centre of pressure {cop.round(3)} outside the sole")
        return out

    def lowest(self, data) -> float:
        """Height of the lowest sole point [m]."""
        return min(data.oMf[p].translation[2] for p in self.points)

    def sinking(self, model, data) -> bool:
        """Whether a sole point moves down (needs velocities in ``data``)."""
        return any(
            pin.getFrameVelocity(model, data, p, pin.LOCAL_WORLD_ALIGNED).linear[2] < 0.0
            for p in self.points
        )


def _welded(c: ContactState, data: pin.Data) -> list:
    """The sole frame welded in 6D, the foot's own hinges (the toes') locked with it."""
    return [Weld(c.side, c.sole, data.oMf[c.sole])] + [
        JointLock(f"{c.side}_{c.model.names[j]}_lock", c.model, j, data.joints[j].joint_q[0])
        for j in c.hinges
    ]


def _pinned(c: ContactState, data: pin.Data) -> list:
    """The four sole corners pinned in 3D."""
    return [PointContact(f"{c.side}_{i}", p, data.oMf[p].translation)
            for i, p in enumerate(c.points)]  # fmt: skip


# contact kind -> (contact, data -> its constraints where the foot is); the names are
# humanoid.variants.CONTACT_KINDS'
CONTACT_CONSTRAINTS = {"weld": _welded, "points": _pinned}
