"""Joint angles as a gait lab reports them, for any humanoid.

A gait lab reports the pelvis against the room, and the hip, knee and ankle as rotations of one
segment against the next (pelvis, thigh, shank, foot): flexion first, about the proximal
segment's lateral axis, then ab/adduction, then rotation about the distal segment's long axis
(a Cardan sequence). Here the segments are found from the model's tree, whatever its joints
(one spherical hip, or three hinges in any order): for each foot, the chain from the root to its
sole; the knee is the one-DoF joint of that chain nearest the middle of the leg; the thigh is the
body the knee hangs from, the shank the knee's body, the foot the sole frame. Angles are zero in
the model's standing posture and signed as the clinic signs them:

- pelvis: anterior tilt, obliquity (the side's own hip up), rotation (the side's hip forward),
  against the direction of progression (x);
- hip: flexion, adduction, internal rotation; knee: flexion; ankle: dorsiflexion
  (all in degrees).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from ..model import SIDES

__all__ = [
    "ANGLES",
    "ArmChain",
    "LegChain",
    "arm_chains",
    "clinical_angles",
    "leg_chains",
    "leg_joint_weights",
    "torso_frame",
]

# the angles of one side, in order
ANGLES = (
    "pelvis_tilt", "pelvis_obliquity", "pelvis_rotation", "hip_flexion", "hip_adduction",
    "hip_rotation", "knee_flexion", "ankle_dorsiflexion",
)  # fmt: skip

# Torso link names of the supported models (ours, example-robot-data's human and Talos).
TORSO_NAMES = ("thorax", "middle_thorax", "torso_2_link", "torso")


def torso_frame(model, arms=()) -> int | None:
    """The torso's frame: the first of :data:`TORSO_NAMES` the model has, else the frame of the
    joint the ``arms`` (:class:`ArmChain` s) hang from (the g1's waist: any humanoid's trunk),
    else None."""
    for name in TORSO_NAMES:
        if model.existFrame(name):
            return model.getFrameId(name)
    for arm in arms:
        parent = model.parents[arm.joints[0]]
        if parent > 1:  # not the pelvis
            return model.getFrameId(model.names[parent], pin.FrameType.JOINT)
    return None


class LegChain:
    """The joints and segments of one leg (see the module docstring)."""

    def __init__(self, h, side: str) -> None:
        model = h.model
        self.side = side
        self.sole = h.sole_id(side)
        chain, j = [], model.frames[self.sole].parentJoint
        while j > 0:
            chain.append(j)
            j = model.parents[j]
        chain = chain[::-1]  # root first
        if len(chain) < 3 or model.joints[chain[0]].shortname() != "JointModelFreeFlyer":
            raise ModelError(f"{h.source}: the {side} foot does not hang from a free-flyer root")
        self.joints = chain[1:]
        data = model.createData()
        q0 = h.standing_configuration()
        pin.framesForwardKinematics(model, data, q0)
        hip = data.oMi[self.joints[0]].translation
        ankle = data.oMf[self.sole].translation
        middle = (hip + ankle) / 2
        hinges = [j for j in self.joints[1:-1] if model.joints[j].nv == 1]
        if not hinges:
            raise ModelError(f"{h.source}: the {side} leg has no knee (a one-DoF joint)")
        self.knee = min(hinges, key=lambda j: np.linalg.norm(data.oMi[j].translation - middle))
        self.thigh = model.parents[self.knee]
        self.knee_placement = model.jointPlacements[self.knee].rotation.copy()
        # the standing posture's relative rotations: the zero of every angle
        self.zero = [r.copy() for r in self.segments(data)]

    def segments(self, data) -> tuple[np.ndarray, ...]:
        """Rotations (pelvis, thigh, shank, foot) in the world."""
        pelvis = data.oMi[1].rotation
        thigh = data.oMi[self.thigh].rotation @ self.knee_placement
        return pelvis, thigh, data.oMi[self.knee].rotation, data.oMf[self.sole].rotation

    def angles(self, data, heading: float = 0.0) -> np.ndarray:
        """The side's :data:`ANGLES` [deg] from kinematics already computed in ``data``; the
        pelvis's against the room turned to ``heading`` [rad] (the direction of progression,
        about the vertical: 0 along x)."""
        pelvis, thigh, shank, foot = self.segments(data)
        p0, t0, s0, f0 = self.zero
        sign = 1.0 if self.side == "right" else -1.0
        # each segment against the one above it, in the standing posture's world axes:
        # distal = proximal proximal0^T D distal0, so D = proximal0 proximal^T distal distal0^T
        hip = _yxz(p0 @ pelvis.T @ thigh @ t0.T)
        knee = _yxz(t0 @ thigh.T @ shank @ s0.T)
        ankle = _yxz(s0 @ shank.T @ foot @ f0.T)
        return np.concatenate([self.pelvis_angles(pelvis, heading), np.degrees([
            -hip[0], sign * hip[1], sign * hip[2], knee[0], -ankle[0],
        ])])  # fmt: skip

    def pelvis_angles(self, pelvis: np.ndarray, heading: float = 0.0) -> np.ndarray:
        """(tilt, obliquity, rotation) [deg] of the pelvis's world rotation against the room
        turned to ``heading`` [rad] (a gait lab's axes along the direction of progression)."""
        c, s = math.cos(heading), math.sin(heading)
        room = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        tilt, obl, rot = _yxz(room.T @ pelvis @ self.zero[0].T)
        sign = 1.0 if self.side == "right" else -1.0
        return np.degrees([tilt, -sign * obl, sign * rot])


def _yxz(R: np.ndarray) -> tuple[float, float, float]:
    """Angles (a, b, c) [rad] with R = Ry(a) Rx(b) Rz(c)."""
    b = math.asin(float(np.clip(-R[1, 2], -1.0, 1.0)))
    a = math.atan2(R[0, 2], R[2, 2])
    c = math.atan2(R[1, 0], R[1, 1])
    return a, b, c


def leg_chains(h) -> dict[str, LegChain]:
    """Both legs' chains of a humanoid."""
    return {s: LegChain(h, s) for s in SIDES}


def leg_joint_weights(model, chains: dict[str, LegChain], legs: float, others: float,
                      arms: dict | None = None, arm: float = 0.0) -> np.ndarray:  # fmt: skip
    """A weight per joint velocity (the free flyer's six excluded): ``legs`` on the legs'
    joints, ``arm`` on the joints of ``arms`` (:class:`ArmChain` s, if given), ``others`` on
    every other joint."""
    w = np.full(model.nv - 6, others)
    groups = [(c, legs) for c in chains.values()] + [(a, arm) for a in (arms or {}).values()]
    for chain, weight in groups:
        for j in chain.joints:
            i = model.joints[j].idx_v - 6
            w[i : i + model.joints[j].nv] = weight
    return w


def clinical_angles(h, q, chains: dict[str, LegChain] | None = None) -> dict[str, np.ndarray]:
    """Gait-lab angles [deg] of a state or a sequence of states ((N, nq)): for each side, an
    array (..., 8) in the order of :data:`ANGLES`."""
    chains = chains or leg_chains(h)
    model = h.model
    data = model.createData()
    qs = np.atleast_2d(np.asarray(q, dtype=float))
    out = {s: np.zeros((len(qs), len(ANGLES))) for s in SIDES}
    for k, qk in enumerate(qs):
        pin.framesForwardKinematics(model, data, qk)
        for s in SIDES:
            out[s][k] = chains[s].angles(data)
    if np.ndim(q) == 1:
        return {s: a[0] for s, a in out.items()}
    return out


class ArmChain:
    """One arm, found from the model's tree whatever its joints: the subtree that hangs from
    the trunk on the side's side, above the hips, without a leg in it. Its shoulder is the
    highest joint above the elbow, the elbow the joint named so (else the one nearest the
    middle of the arm), the hand the joint furthest from the shoulder. Two angles, zero in the
    standing posture [deg]: the shoulder's flexion (the upper arm's swing forward in the
    trunk's sagittal plane) and the elbow's flexion (the angle between upper arm and forearm).
    """

    def __init__(self, h, side: str, legs: dict[str, LegChain]) -> None:
        model = h.model
        self.side = side
        data = model.createData()
        pin.framesForwardKinematics(model, data, h.standing_configuration())
        leg = {j for c in legs.values() for j in c.joints}
        hip = data.oMi[legs[side].joints[0]].translation
        sign = 1.0 if side == "left" else -1.0
        subtree = {j: set(model.subtrees[j]) for j in range(2, model.njoints)}
        root = None
        for j in range(2, model.njoints):  # tree order: a parent before its children
            p = data.oMi[j].translation
            if (j not in leg and not subtree[j] & leg and sign * p[1] > abs(hip[1]) * 0.5
                    and p[2] > 1.2 * hip[2]):  # fmt: skip
                root = j
                break
        if root is None:
            raise ModelError(f"{h.source}: no {side} arm (a subtree beside the trunk)")
        joints = sorted(subtree[root])
        pos = {j: data.oMi[j].translation.copy() for j in joints}
        named = [j for j in joints if "elbow" in model.names[j].lower()]
        top = max(joints, key=lambda j: pos[j][2])
        self.hand = max(joints, key=lambda j: np.linalg.norm(pos[j] - pos[top]))
        middle = (pos[top] + pos[self.hand]) / 2
        self.elbow = named[0] if named else min(
            joints, key=lambda j: np.linalg.norm(pos[j] - middle))  # fmt: skip
        above = [j for j in joints if j < self.elbow and j in model.supports[self.elbow]]
        self.shoulder = max(above or [root], key=lambda j: pos[j][2])
        self.joints = joints
        self.torso = torso_frame(model, [self])
        self.trunk0 = self.trunk(data).copy()  # the trunk's axes standing (any convention)
        self.zero = np.zeros(2)
        self.zero = self.angles(data)

    def trunk(self, data) -> np.ndarray:
        return data.oMf[self.torso].rotation if self.torso is not None else data.oMi[1].rotation

    def vectors(self, data) -> tuple[np.ndarray, np.ndarray]:
        """The upper arm (shoulder to elbow) and the forearm (elbow to hand), world [m]."""
        s, e, w = (data.oMi[j].translation for j in (self.shoulder, self.elbow, self.hand))
        return e - s, w - e

    def angles(self, data) -> np.ndarray:
        """(shoulder flexion, elbow flexion) [deg] from kinematics already in ``data``."""
        upper, fore = self.vectors(data)
        d = self.trunk0 @ self.trunk(data).T @ upper  # in the standing trunk's world axes
        flexion = math.atan2(d[0], -d[2])
        cos = upper @ fore / (np.linalg.norm(upper) * np.linalg.norm(fore))
        elbow = math.acos(float(np.clip(cos, -1.0, 1.0)))
        return np.degrees([flexion, elbow]) - self.zero


def arm_chains(h, legs: dict[str, LegChain] | None = None) -> dict[str, ArmChain]:
    """Both arms of a humanoid (empty if it has none: see :class:`ArmChain`)."""
    legs = legs or leg_chains(h)
    try:
        return {s: ArmChain(h, s, legs) for s in SIDES}
    except ModelError:
        return {}
