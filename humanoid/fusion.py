"""Fusion of hinge triplets into ball joints (``JointModelSpherical``), and the state maps.

URDF has no ball joint, so human models write a shoulder or a hip as three revolute joints
through two massless links (an Euler-angle triplet). Such a triplet gimbal-locks when its middle
angle reaches +-90 deg: the mass matrix becomes singular there (cond(M) ~ 1e15 on
example-robot-data's human at its hip limit). :func:`fuse_ball_joints` replaces every triplet
that meets at one point with mutually orthogonal axes through massless links by one spherical
joint (a unit quaternion in q, the angular velocity in the child frame in v), keeping every
placement and inertia exactly.

Geometry of one triplet (joints j1 -> j2 -> j3, placements P1, P2, P3 with P2, P3 pure
rotations, axes a1, a2, a3 in their own joint frames): with G = R(P2) R(P3), b2 = R(P2) a2 and
b3 = G a3, the child frame's orientation relative to j1's frame is

    R(a1, t1) R(b2, t2) R(b3, t3) G  =  G R_s,

so the fused joint sits at P1 P2 P3 and its rotation is R_s = G^T W G with
W = R(a1, t1) R(b2, t2) R(b3, t3). The angular velocity in j1's frame is
a1 t1' + R(a1, t1) b2 t2' + R(a1, t1) R(b2, t2) b3 t3', and the spherical joint's velocity is
that vector in the child frame.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .errors import ConfigurationError, ModelError, finite_rows, finite_vector

__all__ = ["BallJoint", "Fusion", "fuse_ball_joints"]

REVOLUTE = {"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned"}
TOL = 1e-9
_EYE = np.eye(3)


def quaternions(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (x, y, z, w) of rotation matrices (..., 3, 3), as Eigen makes them:
    its own formula where the trace is positive (w > 0), Pinocchio's conversion elsewhere."""
    trace = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    t = np.sqrt(np.maximum(trace, 0.0) + 1.0)
    k = 0.5 / t
    quat = np.stack([(R[..., 2, 1] - R[..., 1, 2]) * k, (R[..., 0, 2] - R[..., 2, 0]) * k,
                     (R[..., 1, 0] - R[..., 0, 1]) * k, 0.5 * t], axis=-1)  # fmt: skip
    for i in zip(*np.nonzero(trace <= 0.0), strict=True):  # Eigen's other branches
        quat[i] = pin.Quaternion(R[i]).coeffs()
    return quat


def joint_axis(jmodel) -> np.ndarray:
    """Rotation axis of a 1-DoF revolute joint model, in its joint frame."""
    jdata = jmodel.createData()
    jmodel.calc(jdata, np.zeros(jmodel.nq))
    return np.array(jdata.S).reshape(6, -1)[3:, 0].copy()


def euler_solutions(Wp: np.ndarray, s) -> tuple[np.ndarray, np.ndarray]:
    """The two Euler-angle solutions (middle angle b, and pi - b) of rotations
    ``Wp = Rx(s t1) Ry(s t2) Rz(s t3)``, shape (..., 3, 3), ``s`` = +-1 the handedness of the
    axes (broadcast over the leading dimensions). Returns two (..., 3) arrays of angles [rad];
    the second is wrapped to [-pi, pi), the first is as atan2/asin give it."""
    s = np.asarray(s, dtype=float)[..., None]
    beta = np.arcsin(np.clip(Wp[..., 0, 2], -1.0, 1.0))
    alpha = np.arctan2(-Wp[..., 1, 2], Wp[..., 2, 2])
    gamma = np.arctan2(-Wp[..., 0, 1], Wp[..., 0, 0])
    first = s * np.stack([alpha, beta, gamma], axis=-1)
    second = s * np.stack([alpha + np.pi, np.pi - beta, gamma + np.pi], axis=-1)
    return first, (second + np.pi) % (2 * np.pi) - np.pi


def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    return pin.exp3(np.asarray(axis) * angle)


@dataclass(frozen=True)
class BallJoint:
    """One fused triplet: its new joint and the three hinges it replaces."""

    name: str
    joint_id: int  # in the fused model
    hinges: tuple[str, str, str]  # names in the Euler model
    hinge_ids: tuple[int, int, int]  # in the Euler model
    axes: np.ndarray  # (3, 3): columns a1, b2, b3 in j1's frame
    G: np.ndarray  # (3, 3): rotation of the child's zero frame relative to j1's frame

    def rotation(self, angles) -> np.ndarray:
        """R_s for three hinge angles [rad]."""
        W = _rot(self.axes[:, 0], angles[0]) @ _rot(self.axes[:, 1], angles[1])
        W = W @ _rot(self.axes[:, 2], angles[2])
        return self.G.T @ W @ self.G

    def velocity_map(self, angles) -> np.ndarray:
        """3x3 matrix E with (child-frame angular velocity) = E @ (hinge rates)."""
        R1 = _rot(self.axes[:, 0], angles[0])
        R2 = _rot(self.axes[:, 1], angles[1])
        cols = np.column_stack([self.axes[:, 0], R1 @ self.axes[:, 1], R1 @ R2 @ self.axes[:, 2]])
        Rs = self.rotation(angles)
        return (self.G @ Rs).T @ cols

    def angles(self, Rs: np.ndarray, lower=None, upper=None, hint=None) -> np.ndarray:
        """Hinge angles [rad] of a rotation.

        A rotation has two Euler-angle solutions (middle angle b or pi - b). The one inside the
        limits is returned; when both are, the one nearer ``hint`` (e.g. the previous angles of
        a trajectory), else the one with |middle angle| <= pi/2.
        """
        C = self.axes
        s = np.sign(np.linalg.det(C))
        Wp = C.T @ (self.G @ Rs @ self.G.T) @ C  # = Rx(s t1) Ry(s t2) Rz(s t3)
        candidates = list(euler_solutions(Wp, s))
        if lower is not None and upper is not None:
            inside = [
                c for c in candidates if np.all(c >= lower - 1e-12) and np.all(c <= upper + 1e-12)
            ]
            candidates = inside or candidates
        if hint is not None:
            return min(candidates, key=lambda c: np.abs(np.angle(np.exp(1j * (c - hint)))).sum())
        return candidates[0]


@dataclass(frozen=True)
class Fusion:
    """The map between an Euler model (hinge triplets) and its fused model (ball joints)."""

    euler_model: pin.Model
    model: pin.Model
    balls: tuple[BallJoint, ...]
    copied: tuple[tuple[int, int], ...]  # (euler joint id, fused joint id) for other joints

    @functools.cached_property
    def _plan(self):
        """The index arrays of :meth:`to_quaternion`: the copied joints' coordinates (Euler
        model, fused model), the balls' hinge coordinates (nb, 3) and their own starts, and
        the balls' axes (nb, 3 hinges, 3), their cross-product matrices and outer products
        (nb, 3, 3, 3), G and G^T (nb, 3, 3). Reading ``model.joints[j]`` copies a joint model:
        a map per control step read them hundreds of times."""
        em, fm = self.euler_model, self.model
        src_q, dst_q, src_v, dst_v = [], [], [], []
        for je, jf in self.copied:
            a, b = em.joints[je], fm.joints[jf]
            src_q += range(a.idx_q, a.idx_q + a.nq)
            dst_q += range(b.idx_q, b.idx_q + b.nq)
            src_v += range(a.idx_v, a.idx_v + a.nv)
            dst_v += range(b.idx_v, b.idx_v + b.nv)
        index = [np.array(x, dtype=int) for x in (src_q, dst_q, src_v, dst_v)]
        balls = self.balls
        iq = np.array([[em.joints[j].idx_q for j in b.hinge_ids] for b in balls], dtype=int)
        iv = np.array([[em.joints[j].idx_v for j in b.hinge_ids] for b in balls], dtype=int)
        jq = np.array([fm.joints[b.joint_id].idx_q for b in balls], dtype=int)
        jv = np.array([fm.joints[b.joint_id].idx_v for b in balls], dtype=int)
        axes = np.array([b.axes.T for b in balls]).reshape(len(balls), 3, 3)
        cross = np.array([[pin.skew(a) for a in b.axes.T] for b in balls]).reshape(-1, 3, 3, 3)
        outer = axes[..., :, None] * axes[..., None, :]
        G = np.array([b.G for b in balls]).reshape(-1, 3, 3)
        # the quaternions' and velocities' places in q and v, (nb, 4) and (nb, 3)
        qcols, vcols = jq[:, None] + np.arange(4), jv[:, None] + np.arange(3)
        return (*index, iq, iv, qcols, vcols, axes, cross, outer, G,
                G.transpose(0, 2, 1).copy())  # fmt: skip

    def to_quaternion(self, q_euler, v_euler=None):
        """Map an Euler-model state to the fused model: ``(q, v)`` (``v`` None if not given);
        one state, or a sequence of them ((N, nq) and (N, nv): mapped at once).

        The balls' rotations and velocities are :meth:`BallJoint.rotation` and
        :meth:`BallJoint.velocity_map`'s, computed for all balls (and all states) at once (each
        hinge's rotation by Rodrigues' formula, cos I + sin [a]x + (1 - cos) a a^T; equal to
        the per-ball products to 1e-15), the quaternions by :func:`quaternions`."""
        em, fm = self.euler_model, self.model
        one = np.ndim(q_euler) < 2
        q_euler = finite_rows(q_euler, em.nq, "q", "nq")
        n = len(q_euler)
        q = np.zeros((n, fm.nq))
        v = None if v_euler is None else np.zeros((n, fm.nv))
        if v is not None:
            v_euler = finite_rows(v_euler, em.nv, "v", "nv", n)
        (src_q, dst_q, src_v, dst_v, iq, iv, qcols, vcols,
         axes, cross, outer, G, Gt) = self._plan  # fmt: skip
        q[:, dst_q] = q_euler[:, src_q]
        if v is not None:
            v[:, dst_v] = v_euler[:, src_v]
        if len(iq):
            th = q_euler[:, iq]  # (N, nb, 3 hinges)
            c, s = np.cos(th)[..., None, None], np.sin(th)[..., None, None]
            R = c * _EYE + s * cross + (1.0 - c) * outer  # (N, nb, 3 hinges, 3, 3)
            R1 = R[:, :, 0]
            R12 = R1 @ R[:, :, 1]
            Rs = Gt @ (R12 @ R[:, :, 2]) @ G
            q[:, qcols] = quaternions(Rs)
            if v is not None:
                cols = np.stack([np.broadcast_to(axes[:, 0], R1.shape[:-1]),
                                 (R1 @ axes[:, 1, :, None])[..., 0],
                                 (R12 @ axes[:, 2, :, None])[..., 0]], axis=-1)  # fmt: skip
                E = np.swapaxes(G @ Rs, -1, -2) @ cols
                v[:, vcols] = (E @ v_euler[:, iv][..., None])[..., 0]
        if one:
            return q[0], None if v is None else v[0]
        return q, v

    def to_euler(self, q, v=None, hint=None):
        """Map a fused-model state back to hinge angles and rates: ``(q_euler, v_euler)``.

        ``hint``: an Euler-model configuration near the answer, to choose between the two
        Euler-angle solutions of a ball joint when both are inside the limits.

        Raises:
            ConfigurationError: ``v`` is given and a triplet is at gimbal lock, where hinge
                rates are not defined.
        """
        em, fm = self.euler_model, self.model
        q = finite_vector(q, fm.nq, "q", "nq")
        qe = np.zeros(em.nq)
        ve = None if v is None else np.zeros(em.nv)
        if ve is not None:
            v = finite_vector(v, fm.nv, "v", "nv")
        for je, jf in self.copied:
            a, b = em.joints[je], fm.joints[jf]
            qe[a.idx_q : a.idx_q + a.nq] = q[b.idx_q : b.idx_q + b.nq]
            if ve is not None:
                ve[a.idx_v : a.idx_v + a.nv] = v[b.idx_v : b.idx_v + b.nv]
        for ball in self.balls:
            jf = fm.joints[ball.joint_id]
            quat = q[jf.idx_q : jf.idx_q + 4]
            Rs = pin.Quaternion(quat / np.linalg.norm(quat)).toRotationMatrix()
            iq = [em.joints[j].idx_q for j in ball.hinge_ids]
            lim = em.lowerPositionLimit[iq], em.upperPositionLimit[iq]
            th = ball.angles(Rs, *lim, None if hint is None else np.asarray(hint)[iq])
            qe[iq] = th
            if ve is not None:
                E = ball.velocity_map(th)
                if np.linalg.cond(E) > 1e10:
                    raise ConfigurationError(
                        f"ball joint {ball.name!r} is at gimbal lock for its hinges "
                        f"{', '.join(ball.hinges)} (middle angle {th[1]:.6f} rad): "
                        "hinge rates are undefined there"
                    )
                iv = [em.joints[j].idx_v for j in ball.hinge_ids]
                ve[iv] = np.linalg.solve(E, v[jf.idx_v : jf.idx_v + 3])
        return qe, ve


def _massless(inertia) -> bool:
    return inertia.mass <= TOL and np.abs(inertia.inertia).max() <= TOL


def _triplet_axes(model, j1, j2, j3) -> tuple[np.ndarray, np.ndarray]:
    """Axes (a1, b2, b3) of a hinge triplet in j1's frame, and G = R(P2) R(P3)."""
    P2 = model.jointPlacements[j2].rotation
    G = P2 @ model.jointPlacements[j3].rotation
    axes = np.column_stack(
        [joint_axis(model.joints[j1]), P2 @ joint_axis(model.joints[j2]),
         G @ joint_axis(model.joints[j3])]
    )  # fmt: skip
    return axes, G


def find_triplets(model: pin.Model, geometry_models) -> list[tuple[int, int, int]]:
    children: dict[int, list[int]] = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        children[model.parents[j]].append(j)
    carrying = {g.parentJoint for gm in geometry_models for g in gm.geometryObjects}
    plain = {pin.FrameType.JOINT, pin.FrameType.BODY}
    framed = {f.parentJoint for f in model.frames if f.type not in plain}
    triplets = []
    used = set()
    for j1 in range(1, model.njoints):
        if j1 in used:
            continue
        chain = [j1]
        while len(chain) < 3 and len(children[chain[-1]]) == 1:
            chain.append(children[chain[-1]][0])
        if len(chain) != 3 or any(model.joints[j].shortname() not in REVOLUTE for j in chain):
            continue
        j1, j2, j3 = chain
        if any(np.abs(model.jointPlacements[j].translation).max() > TOL for j in (j2, j3)):
            continue
        if not (_massless(model.inertias[j1]) and _massless(model.inertias[j2])):
            continue
        if {j1, j2} & (carrying | framed):
            continue
        axes, _ = _triplet_axes(model, j1, j2, j3)
        if np.abs(axes.T @ axes - np.eye(3)).max() > 1e-9:
            continue
        triplets.append((j1, j2, j3))
        used.update(chain)
    return triplets


def ball_name(model, ids) -> str:
    names = [model.names[j] for j in ids]
    prefix = names[0]
    for n in names[1:]:
        while not n.startswith(prefix):
            prefix = prefix[:-1]
    prefix = prefix.rstrip("_")
    if not prefix or model.existJointName(prefix):
        prefix = names[0] + "_ball"
    return prefix


def _add_ball(model: pin.Model, new: pin.Model, parent: int, triplet) -> BallJoint:
    """The spherical joint added to ``new`` under ``parent`` for a hinge triplet of ``model``."""
    j1, j2, j3 = triplet
    P = model.jointPlacements[j1] * model.jointPlacements[j2] * model.jointPlacements[j3]
    name = ball_name(model, triplet)
    idx = [model.joints[k].idx_v for k in triplet]
    jid = new.addJoint(
        parent,
        pin.JointModelSpherical(),
        P,
        name,
        model.effortLimit[idx],
        model.velocityLimit[idx],
        -np.ones(4),
        np.ones(4),
    )
    new.inertias[jid] = model.inertias[j3]
    axes, G = _triplet_axes(model, j1, j2, j3)
    names = tuple(model.names[k] for k in triplet)
    return BallJoint(name, jid, names, triplet, axes, G)


def _fused_joints(model: pin.Model, triplets):
    """The fused model's joints: each triplet's ball, the other joints copied with their
    limits and dynamics; (the model, joint map old -> new, balls, (old, new) copied)."""
    first = {t[0]: t for t in triplets}
    inner = {j for t in triplets for j in t[1:]}
    new = pin.Model()
    new.name = model.name
    new.gravity = model.gravity
    jmap = {0: 0}
    balls, copied = [], []
    for j in range(1, model.njoints):
        if j in inner:
            continue
        parent = jmap[model.parents[j]]
        if j in first:
            balls.append(_add_ball(model, new, parent, first[j]))
            for k in first[j]:
                jmap[k] = balls[-1].joint_id
            continue
        jm = model.joints[j]
        sq, sv = slice(jm.idx_q, jm.idx_q + jm.nq), slice(jm.idx_v, jm.idx_v + jm.nv)
        jid = new.addJoint(
            parent,
            jm,
            model.jointPlacements[j],
            model.names[j],
            model.effortLimit[sv],
            model.velocityLimit[sv],
            model.lowerPositionLimit[sq],
            model.upperPositionLimit[sq],
        )
        new.inertias[jid] = model.inertias[j]
        nj = new.joints[jid]
        for attr in ("damping", "friction", "armature", "rotorInertia", "rotorGearRatio"):
            getattr(new, attr)[nj.idx_v : nj.idx_v + nj.nv] = getattr(model, attr)[sv]
        jmap[j] = jid
        copied.append((j, jid))
    return new, jmap, balls, copied


def _fused_frames(model: pin.Model, new: pin.Model, jmap: dict, balls) -> dict[int, int]:
    """The frames of ``model`` added to the fused model ``new``: the frame map old -> new."""
    fmap = {0: 0}
    ball_of = {j: b for b in balls for j in b.hinge_ids}
    for fid in _parents_first(model):
        f = model.frames[fid]
        pj = f.parentJoint
        ball = ball_of.get(pj)
        is_joint = f.type == pin.FrameType.JOINT
        if ball is not None and (is_joint or pj != ball.hinge_ids[2]):
            if is_joint and pj == ball.hinge_ids[0]:
                fmap[fid] = new.addJointFrame(ball.joint_id, fmap[f.parentFrame])
            else:  # intermediate links and the inner hinges' frames fold into the ball
                fmap[fid] = new.getFrameId(ball.name, pin.FrameType.JOINT)
        elif is_joint:
            fmap[fid] = new.addJointFrame(jmap[pj], fmap[f.parentFrame])
        else:
            frame = pin.Frame(f.name, jmap[pj], fmap[f.parentFrame], f.placement, f.type, f.inertia)
            fmap[fid] = new.addFrame(frame, False)
    return fmap


def fuse_ball_joints(model: pin.Model, geometry_models=()):
    """Replace every fusible hinge triplet by a spherical joint.

    Args:
        model: The Euler model (it is not modified).
        geometry_models: Geometry models of ``model`` to carry over to the fused model.

    Returns:
        ``(fusion, geometry_models)``: the :class:`Fusion` (with the new model and the state
        maps) and the geometry models re-attached to the fused model.
    """
    triplets = find_triplets(model, geometry_models)
    new, jmap, balls, copied = _fused_joints(model, triplets)
    fmap = _fused_frames(model, new, jmap, balls)
    new_geoms = []
    for gm in geometry_models:
        ng = pin.GeometryModel()
        for g in gm.geometryObjects:
            c = g.copy()
            c.parentJoint = jmap[g.parentJoint]
            c.parentFrame = fmap[g.parentFrame]
            ng.addGeometryObject(c)
        new_geoms.append(ng)
    fusion = Fusion(model, new, tuple(balls), tuple(copied))
    return fusion, new_geoms


def _parents_first(model: pin.Model) -> list[int]:
    """Frame ids (without the universe) ordered so that every frame's parent frame comes
    before it (a reduced model's frames may name a later frame as their parent)."""
    done, order = {0}, []
    pending = list(range(1, model.nframes))
    while pending:
        left = []
        for f in pending:
            if model.frames[f].parentFrame in done:
                done.add(f)
                order.append(f)
            else:
                left.append(f)
        if len(left) == len(pending):
            raise ModelError("the frames' parents form a cycle")
        pending = left
    return order
