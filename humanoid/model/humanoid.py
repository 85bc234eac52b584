"""The loaded body: :class:`Humanoid` (its model, geometry, feet and postures) and the checks
of its configurations (:func:`check_configuration`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..errors import ConfigurationError, ModelError, finite_vector
from ..fusion import Fusion

__all__ = [
    "QUATERNION_TOLERANCE",
    "OTHER_SIDE",
    "SIDES",
    "Humanoid",
    "check_configuration",
    "child_link",
    "frame_hint",
    "quaternion_rows",
    "upright",
    "world_box",
]

SIDES = ("left", "right")
OTHER_SIDE = {"left": "right", "right": "left"}


@dataclass(eq=False)
class Humanoid:
    """A humanoid loaded into Pinocchio, standing along +Z with a free-flyer pelvis.

    Attributes:
        model: The Pinocchio model (free-flyer root, ball joints fused in quaternion mode).
        data: A ``pin.Data`` for ``model``.
        visual_model: Visual geometry (``pin.GeometryModel``).
        collision_model: Collision geometry (``pin.GeometryModel``).
        feet: Sole frame names, (left, right).
        contact_points: Sole contact frame names per side: heel inner/outer, toe inner/outer.
        ball_joints: ``"quaternion"`` or ``"euler"``.
        source: The file it came from, or ``"<string>"``.
        fusion: The Euler <-> quaternion state maps (None in Euler mode).
        euler_model: The model with hinge triplets (the same as ``model`` in Euler mode).
        recipe: What loads this body again on any machine (:func:`load_recipe`): the URDF
            text (and the path it came from), or an example-robot-data robot's name, with the
            loading options. Saved runs carry it.
        postures: Named configurations of this model from an SRDF's group states (the root at
            the origin; joints the SRDF does not name at their upright value).
        reference_posture: The posture a robot starts from (example-robot-data's, e.g.
            ``half_sitting``), or None: :meth:`reference_configuration`.
    """

    model: pin.Model
    data: pin.Data
    visual_model: pin.GeometryModel
    collision_model: pin.GeometryModel
    feet: tuple[str, str]
    contact_points: dict[str, tuple[str, ...]]
    ball_joints: str
    source: str
    fusion: Fusion | None
    euler_model: pin.Model
    recipe: dict = field(default_factory=dict)
    postures: dict = field(default_factory=dict)
    reference_posture: str | None = None
    _quaternions: np.ndarray | None = field(default=None, repr=False)

    @property
    def mass(self) -> float:
        """Total mass [kg]."""
        return float(sum(inertia.mass for inertia in self.model.inertias))

    @property
    def nq(self) -> int:
        return self.model.nq

    @property
    def nv(self) -> int:
        return self.model.nv

    def frame_id(self, name: str) -> int:
        """Index of a frame by name; raises :class:`ModelError` listing similar names."""
        if not self.model.existFrame(name):
            raise ModelError(f"no frame {name!r} in {self.source}; {frame_hint(self.model)}")
        return self.model.getFrameId(name)

    def sole_id(self, side: str) -> int:
        """Index of a side's sole frame (``"left"`` or ``"right"``)."""
        return self.frame_id(self.feet[SIDES.index(side)])

    def standing_configuration(self) -> np.ndarray:
        """Upright configuration [q]: joints at zero (clipped into their limits), soles on z = 0.

        The pelvis is above the world origin and the lowest sole contact point on z = 0.
        """
        return self._on_floor(upright(self.model))

    def reference_configuration(self, name: str | None = None) -> np.ndarray:
        """A named posture (:attr:`postures`; default :attr:`reference_posture`) standing on the
        floor as :meth:`standing_configuration` does; that one if the body has no posture.

        Raises:
            ModelError: ``name`` is not one of the body's postures.
        """
        name = name or self.reference_posture
        if name is None:
            return self.standing_configuration()
        if name not in self.postures:
            raise ModelError(
                f"{self.source} has no posture {name!r}; it has: "
                f"{', '.join(sorted(self.postures)) or 'none (load it with an SRDF)'}"
            )
        return self._on_floor(self.postures[name].copy())

    def _on_floor(self, q: np.ndarray) -> np.ndarray:
        """q with its root above the origin and the lowest sole contact point on z = 0."""
        m = self.model
        q[:3] = 0.0
        data = m.createData()
        pin.framesForwardKinematics(m, data, q)
        names = [n for side in SIDES for n in self.contact_points[side]]
        if names:
            zmin = min(data.oMf[m.getFrameId(n)].translation[2] for n in names)
        else:  # no sole points: the lowest geometry, else the lowest frame, on z = 0
            boxes = [b for g in (self.collision_model, self.visual_model)
                     if (b := world_box(m, data, g)) is not None]  # fmt: skip
            zmin = (min(b[0][2] for b in boxes) if boxes
                    else min(f.translation[2] for f in data.oMf))  # fmt: skip
        q[2] -= zmin
        return q

    def require_contact_points(self, side: str) -> tuple[str, ...]:
        """The sole contact frames of a side, or a ModelError saying how to give them."""
        names = self.contact_points[side]
        if not names:
            raise ModelError(
                f"{self.source}: the {side} foot {self.feet[SIDES.index(side)]!r} has no "
                "geometry to place sole contact points on, and contacts need them: add "
                f"{side}_heel_inner, {side}_heel_outer, {side}_toe_inner and {side}_toe_outer "
                "frames (or a collision box) to the foot in the URDF, or name other foot links "
                "with load(..., feet=(left, right))"
            )
        return names

    def sole_points(self, side: str) -> np.ndarray:
        """The sole's contact points in the sole frame [m], (n, 3), in the order of
        :meth:`require_contact_points`.

        The points and the sole frame ride on the same foot, so this holds in any pose.
        """
        data = self.model.createData()
        pin.framesForwardKinematics(self.model, data, self.standing_configuration())
        sole = data.oMf[self.sole_id(side)]
        names = self.require_contact_points(side)
        return np.array([sole.actInv(data.oMf[self.frame_id(n)].translation) for n in names])

    def sole_box(self, side: str) -> tuple[np.ndarray, np.ndarray]:
        """Corners (min, max) of the sole's contact points in the sole frame [m] (x, y, z)."""
        pts = self.sole_points(side)
        return pts.min(axis=0), pts.max(axis=0)

    def standing_height(self) -> float:
        """Top of the visual geometry in the standing configuration [m] (soles on z = 0)."""
        data = self.model.createData()
        pin.forwardKinematics(self.model, data, self.standing_configuration())
        box = world_box(self.model, data, self.visual_model)
        if box is None:
            raise ModelError(f"{self.source} has no visual geometry to measure its height")
        return float(box[1][2])

    def body_masses(self) -> dict[str, float]:
        """Mass [kg] carried by each moving body, keyed by its link name."""
        out = {}
        for j in range(1, self.model.njoints):
            mass = self.model.inertias[j].mass
            if mass > 0:
                name = next(
                    (f.name for f in self.model.frames
                     if f.parentJoint == j and f.type == pin.FrameType.BODY),
                    self.model.names[j],
                )  # fmt: skip
                out[name] = float(mass)
        return out

    def to_euler(self, q, v=None, hint=None):
        """State of the Euler model (hinge triplets) for a state of this model, or for a
        sequence of states (arrays of shape (N, nq) and (N, nv): a trajectory).

        ``hint`` (an Euler configuration near the answer) picks between the two Euler-angle
        solutions of a ball joint; see :meth:`humanoid.fusion.Fusion.to_euler`. Along a
        sequence each state's hint is the previous answer, so the angles stay continuous.
        """
        if self.fusion is None:
            return q, v
        if np.ndim(q) != 2:
            return self.fusion.to_euler(q, v, hint)
        qs, vs = [], []
        for i, qi in enumerate(q):
            qe, ve = self.fusion.to_euler(qi, None if v is None else v[i], hint)
            hint = qe
            qs.append(qe)
            vs.append(ve)
        return np.array(qs).reshape(-1, self.euler_model.nq), None if v is None else np.array(vs)

    def from_euler(self, q_euler, v_euler=None):
        """State of this model for a state (or a sequence of states, (N, nq)) of the Euler
        model."""
        if self.fusion is None:
            return q_euler, v_euler
        return self.fusion.to_quaternion(q_euler, v_euler)


def upright(model: pin.Model) -> np.ndarray:
    """Neutral configuration with every 1-DoF joint at zero clipped into its limits."""
    q = pin.neutral(model)
    for jm in model.joints[2:]:
        if jm.nq == 1:
            lo, hi = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
            q[jm.idx_q] = np.clip(0.0, lo, hi) if lo <= hi else 0.0
    return q


def world_box(model, data, geometry_model, joints=None):
    """World bounding box (min, max corners) of the geometry on ``joints`` (all if None).

    Uses ``data.oMi`` as it stands; returns None when no geometry object matches.
    """
    corners = []
    for g in geometry_model.geometryObjects:
        if joints is not None and g.parentJoint not in joints:
            continue
        g.geometry.computeLocalAABB()
        box = g.geometry.aabb_local
        lo, hi = np.array(box.min_), np.array(box.max_)
        M = data.oMi[g.parentJoint] * g.placement
        for i in range(8):
            corners.append(M.act(np.where([(i >> k) & 1 for k in range(3)], hi, lo)))
    if not corners:
        return None
    corners = np.array(corners)
    return corners.min(axis=0), corners.max(axis=0)


def frame_hint(model: pin.Model) -> str:
    """The model's body and operational frames, for a message about a frame it lacks."""
    names = [f.name for f in model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]
    return "frames: " + ", ".join(names)


def child_link(model: pin.Model, joint: int) -> str:
    """The name of the link a joint moves (its first BODY frame)."""
    return next(
        (f.name for f in model.frames if f.parentJoint == joint and f.type == pin.FrameType.BODY),
        model.names[joint],
    )


QUATERNION_TOLERANCE = 1e-4  # a quaternion of q may be off unit norm by this (and is normalised)


def quaternion_rows(model: pin.Model) -> np.ndarray:
    """First q index of each unit quaternion in q (free flyer and ball joints)."""
    rows = []
    for jm in model.joints[1:]:
        name = jm.shortname()
        if name == "JointModelFreeFlyer":
            rows.append(jm.idx_q + 3)
        elif name == "JointModelSpherical":
            rows.append(jm.idx_q)
    return np.array(rows, dtype=int)


_NO_VELOCITY = object()


def check_configuration(h: Humanoid, q, v=_NO_VELOCITY):
    """``q`` (and ``v``) as float arrays of the model's sizes, finite and bounded, every
    quaternion of unit norm to :data:`QUATERNION_TOLERANCE` (normalised); else
    ConfigurationError."""
    q = finite_vector(q, h.nq, "q", "nq")
    if h._quaternions is None:
        h._quaternions = quaternion_rows(h.model)
    if len(h._quaternions):
        idx = h._quaternions[:, None] + np.arange(4)
        norms = np.linalg.norm(q[idx], axis=1)
        off = np.abs(norms - 1.0) > QUATERNION_TOLERANCE
        if off.any():
            i = int(h._quaternions[np.argmax(off)])
            raise ConfigurationError(
                f"q[{i}:{i + 4}] is a quaternion of norm {norms[np.argmax(off)]:.6g}, not 1"
            )
        q[idx] /= norms[:, None]
    if v is _NO_VELOCITY:
        return q
    v = finite_vector(v, h.nv, "v", "nv")
    return q, v
