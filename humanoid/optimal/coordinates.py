"""The body in the coordinates an optimal-control problem wants: a vector space.

The toolkit's model writes a ball joint as a unit quaternion and the pelvis as a free flyer
(a position and a quaternion). A nonlinear program over quaternions needs their norm as
constraints and a Lie-group collocation, and IPOPT converges badly on both (measured: a
standing posture with 8 contact points did not converge in 1000 iterations). So the program
runs on :class:`OcpModel`: the body's Euler model (each ball joint as its URDF's three hinges),
with the free flyer written as three slides (x, y, z) and three hinges (yaw about z, then
pitch about y, then roll about x), optionally with joints locked (the wrists and the neck by
default: they carry little of a walk). Every coordinate is an angle or a length, trapezoidal
collocation is q_{k+1} = q_k + h (v_k + v_{k+1}) / 2 exactly, joint ranges are bounds, and
walking never comes near the triplets' gimbal lock (a middle angle of +-90 deg).

:meth:`OcpModel.to_body` maps a trajectory back to the body's own state (quaternions), and
:attr:`OcpModel.mirror` is the left-right reflection (the plane y = 0) of a state, which a
half stride's symmetry needs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from ..fusion import quaternions

if TYPE_CHECKING:
    from ..model import Humanoid

__all__ = ["OcpModel", "ROOT_NAMES", "build_ocp_model"]

ROOT_NAMES = ("root_x", "root_y", "root_z", "root_yaw", "root_pitch", "root_roll")
# Joints locked by default: they move little mass and little of a walk.
LOCKED = ("wrist", "neck")
_SIDES = {"left": "right", "right": "left", "l": "r", "r": "l"}  # name tokens


@dataclass(frozen=True)
class OcpModel:
    """A body in vector-space coordinates (see the module).

    Attributes:
        model: The Pinocchio model (nq == nv; the first six coordinates are
            :data:`ROOT_NAMES`).
        names: The coordinates' names (the Euler model's joint names after the root's).
        body: The :class:`humanoid.Humanoid` it comes from.
        euler_index: For each coordinate after the root's, its index in the Euler model's q.
        locked: The Euler model's configuration whose values the locked joints keep.
        mirror: (permutation, signs): the reflected state is ``signs * x[permutation]``
            (root_x unchanged, root_y negated, ...).
    """

    model: pin.Model
    names: tuple[str, ...]
    body: Humanoid
    euler_index: np.ndarray
    locked: np.ndarray
    mirror: tuple[np.ndarray, np.ndarray]

    @property
    def n(self) -> int:
        return self.model.nv

    def index(self, name: str) -> int:
        """The coordinate's index."""
        try:
            return self.names.index(name)
        except ValueError:
            raise ModelError(f"no coordinate {name!r} in the optimal-control model") from None

    def reflect(self, x) -> np.ndarray:
        """The mirror image (through y = 0) of configurations or velocities, shape (..., n)."""
        perm, sign = self.mirror
        return sign * np.asarray(x)[..., perm]

    def from_body(self, q, hint=None) -> np.ndarray:
        """Coordinates of a body configuration (or of a sequence of them, shape (N, nq))."""
        h = self.body
        if np.ndim(q) == 2:
            out, prev = [], hint
            for qi in q:
                prev = self.from_body(qi, prev)
                out.append(prev)
            return np.array(out)
        hint_e = None
        if hint is not None:
            hint_e = self.locked.copy()
            hint_e[self.euler_index] = np.asarray(hint)[6:]
        qe, _ = h.to_euler(np.asarray(q, dtype=float), None, hint_e)
        x = np.zeros(self.n)
        x[:3] = qe[:3]
        R = pin.Quaternion(qe[3:7] / np.linalg.norm(qe[3:7])).toRotationMatrix()
        x[3:6] = yaw_pitch_roll(R)
        x[6:] = qe[self.euler_index]
        return x

    def to_body(self, x, v=None):
        """The body's state (q, v) for coordinates (and rates): one state or sequences
        (N, n), mapped at once. ``v`` None gives None.

        The root's rotation is Rz(yaw) Ry(pitch) Rx(roll) and the free flyer's velocity the
        pelvis's twist in its own frame: R^T p' and, with the angles' rates,
        omega = yaw' R^T z + pitch' Rx(roll)^T y + roll' x (what the root's six joints'
        forward kinematics give: tests/test_fusion.py)."""
        x = np.asarray(x, dtype=float)
        one = x.ndim == 1
        x = np.atleast_2d(x)
        n = len(x)
        qe = np.tile(self.locked, (n, 1))
        qe[:, :3] = x[:, :3]
        R = root_rotations(x[:, 3:6])
        qe[:, 3:7] = quaternions(R)
        qe[:, self.euler_index] = x[:, 6:]
        ve = None
        if v is not None:
            v = np.atleast_2d(np.asarray(v, dtype=float))
            ve = np.zeros((n, self.body.euler_model.nv))
            ve[:, :3] = (np.swapaxes(R, 1, 2) @ v[:, :3, None])[..., 0]
            sp, cp = np.sin(x[:, 4]), np.cos(x[:, 4])
            sr, cr = np.sin(x[:, 5]), np.cos(x[:, 5])
            dy, dp, dr = v[:, 3], v[:, 4], v[:, 5]
            ve[:, 3] = dr - dy * sp
            ve[:, 4] = dp * cr + dy * cp * sr
            ve[:, 5] = -dp * sr + dy * cp * cr
            ve[:, self.euler_index - 1] = v[:, 6:]
        q, vb = self.body.from_euler(qe, ve)
        if one:
            return q[0], None if vb is None else vb[0]
        return q, vb


def yaw_pitch_roll(R: np.ndarray) -> np.ndarray:
    """(yaw, pitch, roll) with R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return np.array(pin.rpy.matrixToRpy(R))[::-1].copy()


def root_rotations(ypr: np.ndarray) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll) of rows (N, 3) of (yaw, pitch, roll): (N, 3, 3) (as
    ``pin.rpy.rpyToMatrix(roll, pitch, yaw)``)."""
    cy, sy = np.cos(ypr[:, 0]), np.sin(ypr[:, 0])
    cp, sp = np.cos(ypr[:, 1]), np.sin(ypr[:, 1])
    cr, sr = np.cos(ypr[:, 2]), np.sin(ypr[:, 2])
    return np.stack([
        np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], axis=1),
        np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], axis=1),
        np.stack([-sp, cp * sr, cp * cr], axis=1),
    ], axis=1)  # fmt: skip


def _partner(name: str) -> str:
    """The mirror joint's name: the side token (``left``, ``r``, ...) swapped."""
    return "_".join(_SIDES.get(t, t) for t in name.split("_"))


def build_ocp_model(h, locked=LOCKED) -> OcpModel:
    """The :class:`OcpModel` of a body ``h`` (a free-flyer root); joints whose names contain
    one of ``locked`` keep their standing value."""
    em = h.euler_model
    if em.joints[1].shortname() != "JointModelFreeFlyer":
        raise ModelError("the optimal-control model needs a free-flyer root")
    standing = h.to_euler(h.standing_configuration())[0]
    lock_ids = [j for j in range(2, em.njoints) if any(s in em.names[j] for s in locked)]
    reduced = pin.buildReducedModel(em, lock_ids, standing) if lock_ids else em
    model = pin.Model()
    model.name = f"{em.name}-ocp"
    big = 1e3
    parent = 0
    for name, jm in zip(
        ROOT_NAMES,
        (pin.JointModelPX(), pin.JointModelPY(), pin.JointModelPZ(), pin.JointModelRZ(),
         pin.JointModelRY(), pin.JointModelRX()),
        strict=True,
    ):  # fmt: skip
        lim = (np.array([-big]), np.array([big]))
        parent = model.addJoint(parent, jm, pin.SE3.Identity(), name, np.array([big]),
                                np.array([big]), *lim)  # fmt: skip
    root = parent
    model.appendBodyToJoint(root, reduced.inertias[1], pin.SE3.Identity())
    ids = {0: 0, 1: root}
    for j in range(2, reduced.njoints):
        jm = reduced.joints[j]
        s = slice(jm.idx_q, jm.idx_q + jm.nq)
        ids[j] = model.addJoint(
            ids[reduced.parents[j]], jm, reduced.jointPlacements[j], reduced.names[j],
            reduced.effortLimit[jm.idx_v : jm.idx_v + jm.nv],
            reduced.velocityLimit[jm.idx_v : jm.idx_v + jm.nv],
            reduced.lowerPositionLimit[s], reduced.upperPositionLimit[s],
        )  # fmt: skip
        model.appendBodyToJoint(ids[j], reduced.inertias[j], pin.SE3.Identity())
    model.damping[6:] = reduced.damping[6:]
    model.gravity = reduced.gravity
    for f in reduced.frames[1:]:
        if f.type in (pin.FrameType.OP_FRAME, pin.FrameType.BODY) and f.parentJoint > 0:
            model.addFrame(pin.Frame(f.name, ids[f.parentJoint], 0, f.placement, f.type))
    names = tuple(model.names[1:])
    euler_index = np.array([em.joints[em.getJointId(n)].idx_q for n in names[6:]], dtype=int)
    return OcpModel(model, names, h, euler_index, standing, _mirror(model, names))


def _mirror(model: pin.Model, names) -> tuple[np.ndarray, np.ndarray]:
    """Signed permutation of the reflection through the plane y = 0 (see the module)."""
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    P = np.diag([1.0, -1.0, 1.0])
    perm = np.zeros(len(names), dtype=int)
    sign = np.zeros(len(names))
    for i, name in enumerate(names):
        j = model.getJointId(name)
        other = _partner(name)
        if not model.existJointName(other):
            raise ModelError(f"joint {name!r} has no mirror partner {other!r}")
        k = model.getJointId(other)
        Sj = _axis(model, data, j)
        Sk = _axis(model, data, k)
        if model.joints[j].shortname().startswith("JointModelP"):
            c = float(Sk @ (P @ Sj))  # a slide reflects as a vector
        else:
            c = float(Sk @ (-P @ Sj))  # a rotation axis as a pseudo-vector
        if abs(abs(c) - 1.0) > 1e-6:
            raise ModelError(
                f"joints {name!r} and {other!r} are not mirror images (axis product {c:.3g})"
            )
        perm[i], sign[i] = model.joints[k].idx_v, np.sign(c)
    return perm, sign


def _axis(model, data, j) -> np.ndarray:
    """A 1-dof joint's axis in the world at the neutral configuration."""
    jm = model.joints[j]
    if jm.nv != 1:
        raise ModelError(f"joint {model.names[j]!r} is not a hinge or a slide")
    jd = jm.createData()
    jm.calc(jd, np.zeros(jm.nq))
    S = np.array(jd.S).reshape(6)
    R = data.oMi[j].rotation
    return R @ (S[:3] if np.linalg.norm(S[:3]) > 0.5 else S[3:])
