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

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ..errors import ModelError

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

    @functools.cached_property
    def _data(self) -> pin.Data:
        """Scratch data for the state maps (a walk maps three states per control step)."""
        return self.model.createData()

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
        (N, n). ``v`` None gives None."""
        if np.ndim(x) == 2:
            out = [self.to_body(xi, None if v is None else v[i]) for i, xi in enumerate(x)]
            q = np.array([o[0] for o in out])
            return q, None if v is None else np.array([o[1] for o in out])
        x = np.asarray(x, dtype=float)
        h, em = self.body, self.body.euler_model
        qe = self.locked.copy()
        qe[:3] = x[:3]
        R = root_rotation(x[3:6])
        qe[3:7] = pin.Quaternion(R).coeffs()
        qe[self.euler_index] = x[6:]
        ve = None
        if v is not None:
            v = np.asarray(v, dtype=float)
            ve = np.zeros(em.nv)
            # the free flyer's velocity: the pelvis's twist in its own frame
            data = self._data
            pin.forwardKinematics(self.model, data, x, v)
            ve[:6] = data.v[6].vector
            ve[self.euler_index - 1] = v[6:]
        return h.from_euler(qe, ve)


def yaw_pitch_roll(R: np.ndarray) -> np.ndarray:
    """(yaw, pitch, roll) with R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return np.array(pin.rpy.matrixToRpy(R))[::-1].copy()


def root_rotation(ypr) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll)."""
    return pin.rpy.rpyToMatrix(float(ypr[2]), float(ypr[1]), float(ypr[0]))


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
