"""Foot attachments: a 6D weld of a sole frame, or 3D point contacts at the sole corners; a
joint lock holds a foot's own hinges (the toes') while the foot is welded.

Both attach a frame (or a point) to a world anchor taken where it is when the contact is made,
and are released by removing them from the active set (a transient attachment, as in the seeds).
Forces follow the convention M a = tau - b + J^T lambda: lambda is the force (and torque) that
the ground applies to the foot.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from .base import Constraint

__all__ = ["JointLock", "PointContact", "Weld", "foot_hinges", "packed_rows"]

LOCAL = pin.ReferenceFrame.LOCAL
WORLD_ALIGNED = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


class Weld(Constraint):
    """Frame ``frame_id`` welded to the world placement ``anchor`` (6 rows, LOCAL axes).

    Residual: log6(anchor^-1 oMf) (translation, rotation) in the frame's axes. Jacobian: the
    frame's LOCAL Jacobian (the constraint velocity is the frame's twist). Drift: the frame's
    spatial acceleration at a = 0, in LOCAL axes.
    """

    size = 6

    def __init__(self, name: str, frame_id: int, anchor: pin.SE3) -> None:
        self.name = name
        self.frame_id = frame_id
        self.anchor = anchor.copy()

    def residual(self, model, data):
        return pin.log6(self.anchor.actInv(data.oMf[self.frame_id])).vector

    def jacobian(self, model, data):
        return pin.getFrameJacobian(model, data, self.frame_id, LOCAL)

    def drift(self, model, data):
        return pin.getFrameAcceleration(model, data, self.frame_id, LOCAL).vector

    def residual_jacobian(self, model, data):
        error = self.anchor.actInv(data.oMf[self.frame_id])
        return pin.Jlog6(error) @ self.jacobian(model, data)

    def twin(self, model, baumgarte):
        return _twin(model, self.frame_id, pin.ContactType.CONTACT_6D, LOCAL, self.anchor,
                     baumgarte)  # fmt: skip

    def wrench_world(self, model, data, force: np.ndarray) -> np.ndarray:
        """The contact wrench (force, torque about the frame origin) in world axes [N, N m]."""
        R = data.oMf[self.frame_id].rotation
        return np.concatenate([R @ force[:3], R @ force[3:]])


class PointContact(Constraint):
    """The origin of frame ``frame_id`` held at the world point ``anchor`` (3 rows, world axes).

    Residual: p(q) - anchor. Jacobian: the linear rows of the frame Jacobian in world-aligned
    axes. Drift: the point's classical acceleration at a = 0, world axes.
    """

    size = 3

    def __init__(self, name: str, frame_id: int, anchor: np.ndarray) -> None:
        self.name = name
        self.frame_id = frame_id
        self.anchor = np.array(anchor, dtype=float)

    def residual(self, model, data):
        return data.oMf[self.frame_id].translation - self.anchor

    def jacobian(self, model, data):
        return pin.getFrameJacobian(model, data, self.frame_id, WORLD_ALIGNED)[:3]

    def drift(self, model, data):
        return pin.getFrameClassicalAcceleration(model, data, self.frame_id, WORLD_ALIGNED).linear

    def twin(self, model, baumgarte):
        anchor = pin.SE3(np.eye(3), self.anchor)
        return _twin(model, self.frame_id, pin.ContactType.CONTACT_3D, WORLD_ALIGNED, anchor,
                     baumgarte)  # fmt: skip


class JointLock(Constraint):
    """A one-degree-of-freedom joint held at the angle it had when locked (1 row).

    Residual: q_j - q_anchor. Jacobian: the joint's unit row. Drift: 0. A welded foot with
    toes locks its MTP hinge with it: the weld holds the rearfoot's sole and the lock the toes
    flat beside it, the same motion as the four corner points that the walking controllers
    plan with (heel points on the rearfoot, toe points on the toes), and the weld's wrench is
    the ground's on the whole foot (the lock's torque is internal)."""

    size = 1

    def __init__(self, name: str, model: pin.Model, joint_id: int, angle: float) -> None:
        joint = model.joints[joint_id]
        if joint.nq != 1 or joint.nv != 1:
            raise ModelError(f"a joint lock holds a one-degree-of-freedom joint, and "
                             f"{model.names[joint_id]} has nq = {joint.nq}")  # fmt: skip
        self.name = name
        self.joint_id = joint_id
        self.anchor = float(angle)
        self._row = np.zeros((1, model.nv))
        self._row[0, joint.idx_v] = 1.0

    def residual(self, model, data):
        return np.array([data.joints[self.joint_id].joint_q[0] - self.anchor])

    def jacobian(self, model, data):
        return self._row.copy()

    def drift(self, model, data):
        return np.zeros(1)


def foot_hinges(model: pin.Model, sole_frame: int, point_frames) -> list[int]:
    """The one-degree-of-freedom joints between a sole frame's joint and the joints that
    carry its contact points (a foot with toes: its MTP hinge), in model order."""
    sole_joint = model.frames[sole_frame].parentJoint
    out = set()
    for f in point_frames:
        j = model.frames[f].parentJoint
        while j > sole_joint:
            if model.joints[j].nv == 1:
                out.add(j)
            j = model.parents[j]
    return sorted(out)


def _twin(model, frame_id, kind, reference, anchor, baumgarte) -> pin.RigidConstraintModel:
    """A rigid constraint of frame ``frame_id`` to the world placement ``anchor``, with the
    Baumgarte gains Kp = beta^2, Kd = 2 alpha."""
    frame = model.frames[frame_id]
    cm = pin.RigidConstraintModel(kind, model, frame.parentJoint, frame.placement, 0, anchor,
                                  reference)  # fmt: skip
    cm.setBaumgarteCorrectorParameters(
        pin.BaumgarteCorrectorParameters(baumgarte.beta**2, 2 * baumgarte.alpha)
    )
    return cm


def packed_rows(model: pin.Model, constraints) -> tuple[np.ndarray, np.ndarray] | None:
    """Welds and joint locks as the compiled kernels read them
    (:meth:`humanoid.dynamics.TreeDynamics.constraint_rows`, the welded walk's held torques):
    three ints each (kind: 0 a weld, 1 a lock; a weld's frame's joint; a lock's configuration
    and velocity index) and their reals (a weld: its frame's placement in its joint and its
    anchor, rotation row-major then translation; a lock: its angle), in the constraints'
    order; None if one is of another kind."""
    ints: list[int] = []
    reals: list[np.ndarray] = []
    for c in constraints:
        if isinstance(c, Weld):
            frame = model.frames[c.frame_id]
            ints += [0, frame.parentJoint, 0]
            reals += [frame.placement.rotation.ravel(), frame.placement.translation,
                      c.anchor.rotation.ravel(), c.anchor.translation]  # fmt: skip
        elif isinstance(c, JointLock):
            joint = model.joints[c.joint_id]
            ints += [1, joint.idx_q, joint.idx_v]
            reals.append(np.array([c.anchor]))
        else:
            return None
    return (np.array(ints, dtype=np.int64),
            np.concatenate(reals) if reals else np.zeros(0))  # fmt: skip
