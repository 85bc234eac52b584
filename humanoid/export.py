"""Export a loaded humanoid to MuJoCo's MJCF, and map states between the two.

Every Pinocchio joint becomes a MuJoCo joint: the free flyer a ``freejoint``, spherical joints
``ball`` joints, revolute joints ``hinge`` joints with their axes. MuJoCo refuses moving bodies
without mass (URDF's massless intermediate links), so a joint whose body is massless is merged
with its only child into one MuJoCo body with several joints (applied in order, as the hinge
chain is), keeping every placement and inertia. Inertias are written explicitly (mass, CoM,
full inertia tensor), never from geometry.

:func:`write_mjcf` (``humanoid export --mjcf``) writes a model to simulate, as ours is: a floor
plane, the body's collision geometry colliding with it (boxes, spheres, cylinders: meshes are
left out; a foot without any, spheres of :data:`SOLE_SPHERE` on its sole points, where ours
touches the floor), MuJoCo's soft contacts with their parameters written out (:data:`SOLREF`,
:data:`SOLIMP`, elliptic friction cones), every hinge's range on, a ball joint's as the cone its
three angles' largest bound allows (MuJoCo's ball limit is one angle), and a motor per degree of
freedom (a hinge's on its axis, a ball joint's three on its own x, y and z axes; torque in N m,
unlimited). :func:`to_mjcf` with its defaults is the bare mechanics (no floor, no collisions).

State maps: MuJoCo stores quaternions as (w, x, y, z) and the free joint's linear velocity in
world axes; Pinocchio stores (x, y, z, w) and the linear velocity in the body frame.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple
from xml.sax.saxutils import quoteattr

import numpy as np
import pinocchio as pin

from .errors import ModelError
from .fusion import joint_axis

__all__ = ["SOLIMP", "SOLREF", "StateMap", "mujoco_state", "pinocchio_state", "to_mjcf",
           "write_mjcf"]  # fmt: skip

# MuJoCo's soft contact, its defaults written out: a constraint's reference acceleration is that
# of a spring-damper of time constant 20 ms at critical damping, its impedance 0.9-0.95 over
# 1 mm of penetration (MuJoCo's docs, "Solver parameters")
SOLREF = (0.02, 1.0)
SOLIMP = (0.9, 0.95, 0.001)
# [m] a foot without collision geometry (example-robot-data's human) touches the floor at its
# sole points: spheres this small resting on them
SOLE_SPHERE = 0.005


def _fmt(x) -> str:
    return " ".join(f"{float(v):.17g}" for v in np.ravel(x))


def _short(x) -> str:
    """Parameters as written by hand (0.9, not 0.90000000000000002)."""
    return " ".join(f"{float(v):g}" for v in np.ravel(x))


def _quat_wxyz(R) -> np.ndarray:
    c = pin.Quaternion(np.asarray(R)).coeffs()  # x y z w
    return np.array([c[3], c[0], c[1], c[2]])


def _massless(inertia) -> bool:
    return inertia.mass <= 1e-12


class _Tree(NamedTuple):
    """What the ``<body>`` elements are written from: the model's joint tree and its XML parts."""

    model: pin.Model
    children: dict[int, list[int]]
    names: dict[int, str]  # per joint, its body's name
    geoms: dict[int, list[str]]  # per joint, its body's geoms' XML
    cones: dict[int, float]  # a ball joint's cone [rad]
    extra: str  # the joints' damping attribute
    limits: bool  # hinges keep their ranges


def _geoms(h, collide: bool) -> dict[int, list[str]]:
    """Per joint, its body's geoms' XML (the collision geometry if ``collide``, else visual)."""
    model = h.model
    geoms: dict[int, list[str]] = {}  # per joint, its body's geoms' XML
    for g in (h.collision_model if collide else h.visual_model).geometryObjects:
        geoms.setdefault(g.parentJoint, []).extend(_geom_xml(g))
    if collide:  # a foot without collision geometry touches the floor at its sole points
        for side, points in h.contact_points.items():
            sole = model.frames[h.sole_id(side)]
            if geoms.get(sole.parentJoint):
                continue
            up = sole.placement.rotation[:, 2]  # (the sole's normal, in its joint's axes)
            for name in points:
                f = model.frames[h.frame_id(name)]
                centre = f.placement.translation + SOLE_SPHERE * up
                geoms.setdefault(f.parentJoint, []).append(
                    f'<geom name={quoteattr(name)} type="sphere" size="{SOLE_SPHERE:g}" '
                    f'pos="{_fmt(centre)}"/>')  # fmt: skip
    return geoms


def _tree(h, collide: bool, limits: bool, damping: float) -> _Tree:
    """The joint tree of ``h`` with its bodies' names, geoms, ball joints' cones, damping."""
    model = h.model
    children: dict[int, list[int]] = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        children[model.parents[j]].append(j)
    names = {}
    for f in model.frames:
        if f.type == pin.FrameType.BODY and f.parentJoint not in names:
            names[f.parentJoint] = f.name
    geoms = _geoms(h, collide)
    cones = {}  # a ball joint's cone [rad]: its hinge triplet's largest bound
    if limits and h.fusion is not None:
        em = h.euler_model
        for ball in h.fusion.balls:
            iq = [em.joints[i].idx_q for i in ball.hinge_ids]
            bounds = np.abs(np.r_[em.lowerPositionLimit[iq], em.upperPositionLimit[iq]])
            if np.all(np.isfinite(bounds)):
                cones[ball.joint_id] = float(bounds.max())

    extra = f' damping="{damping:.17g}"' if damping > 0 else ""
    return _Tree(model, children, names, geoms, cones, extra, limits)


def _joint_xml(tree: _Tree, j: int, placement: pin.SE3) -> str:
    """The MJCF joint element of joint ``j`` at ``placement`` in its body's frame."""
    model, cones, extra, limits = tree.model, tree.cones, tree.extra, tree.limits
    jm = model.joints[j]
    kind = jm.shortname()
    name = quoteattr(model.names[j])
    if kind == "JointModelFreeFlyer":
        return f"<freejoint name={name}/>"
    if kind == "JointModelSpherical":
        cone = f' range="0 {cones[j]:.17g}" limited="true"' if j in cones else ""
        return (f'<joint name={name} type="ball" pos="{_fmt(placement.translation)}"'
                f"{cone}{extra}/>")  # fmt: skip
    if jm.nq == 1 and jm.nv == 1:
        axis = placement.rotation @ joint_axis(jm)
        lo, hi = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
        limited = "true" if limits and np.isfinite(lo) and np.isfinite(hi) else "false"
        return (
            f'<joint name={name} type="hinge" pos="{_fmt(placement.translation)}" '
            f'axis="{_fmt(axis)}" range="{lo:.17g} {hi:.17g}" limited="{limited}"{extra}/>'
        )
    raise ModelError(f"no MuJoCo joint for {kind} ({model.names[j]})")


def _body_xml(tree: _Tree, j: int, depth: int) -> list[str]:
    """The ``<body>`` element of joint ``j`` and its subtree (massless joints merged into it)."""
    model, children = tree.model, tree.children
    pad = "  " * depth
    chain = [j]
    offsets = [pin.SE3.Identity()]
    while _massless(model.inertias[chain[-1]]) and len(children[chain[-1]]) == 1:
        nxt = children[chain[-1]][0]
        P = model.jointPlacements[nxt]
        if np.abs(P.translation).max() > 1e-12:
            raise ModelError(f"cannot merge massless {model.names[chain[-1]]}: offset child")
        chain.append(nxt)
        offsets.append(offsets[-1] * P)
    last = chain[-1]
    if _massless(model.inertias[last]) and not children[last]:
        return []  # a massless leaf carries nothing
    P = model.jointPlacements[j]
    name = quoteattr(tree.names.get(last, model.names[last]))
    # the MuJoCo body frame is the last joint's frame at zero angles
    G = offsets[-1]
    frame = P * G
    lines = [f'{pad}<body name={name} pos="{_fmt(frame.translation)}" '
             f'quat="{_fmt(_quat_wxyz(frame.rotation))}">']  # fmt: skip
    for k, jj in enumerate(chain):
        rel = G.inverse() * offsets[k]  # the joint's frame in the body frame
        lines.append(pad + "  " + _joint_xml(tree, jj, rel))
    I = model.inertias[last]
    if I.mass > 0:
        M = I.inertia
        full = [M[0, 0], M[1, 1], M[2, 2], M[0, 1], M[0, 2], M[1, 2]]
        lines.append(f'{pad}  <inertial pos="{_fmt(I.lever)}" mass="{I.mass:.17g}" '
                     f'fullinertia="{_fmt(full)}"/>')  # fmt: skip
    lines += [pad + "  " + x for x in tree.geoms.get(last, [])]
    for child in children[last]:
        lines += _body_xml(tree, child, depth + 1)
    lines.append(f"{pad}</body>")
    return lines


def to_mjcf(h, timestep: float = 1e-3, integrator: str = "RK4", ground: float | None = None,
            limits: bool = False, damping: float = 0.0, motors: bool = False) -> str:  # fmt: skip
    """MJCF text of a Humanoid (see the module docstring).

    Args:
        ground: A friction coefficient: the body's collision geometries then collide with a
            floor plane at z = 0 (elliptic friction cones, MuJoCo's soft contacts with
            :data:`SOLREF` and :data:`SOLIMP`); None: no collisions, the visual geometry only.
        limits: Joints keep their position limits (MuJoCo's soft limit constraints): a hinge
            its range, a ball joint the cone of its three angles' largest bound.
        damping: Joint damping [N m s/rad] on every joint but the free flyer.
        motors: A motor per degree of freedom but the free flyer's (torque [N m], unlimited):
            one per hinge, three per ball joint (about its own x, y, z axes), in joint order.

    Raises:
        ModelError: a joint type that has no MuJoCo counterpart, or a massless body that cannot
            be merged (it has several children or a child with an offset).
    """
    model = h.model
    collide = ground is not None
    tree = _tree(h, collide, limits, damping)
    if model.joints[1].shortname() != "JointModelFreeFlyer":
        raise ModelError("MJCF export expects a free-flyer root")
    g = model.gravity.linear
    lines = [
        f"<mujoco model={quoteattr(model.name or 'humanoid')}>",
        '  <compiler angle="radian" inertiafromgeom="false" autolimits="false"/>',
        f'  <option timestep="{timestep:g}" integrator="{integrator}" gravity="{_fmt(g)}"'
        + (' cone="elliptic"/>' if collide else "/>"),
        f'  <default><geom contype="{int(collide)}" conaffinity="0" rgba="0.7 0.7 0.8 1"'
        + (
            f' friction="{ground:.17g} 0 0" solref="{_short(SOLREF)}" solimp="{_short(SOLIMP)}"/>'
            "</default>"
            if collide
            else "/></default>"
        ),
        "  <worldbody>",
        *(
            [
                f'    <geom name="floor" type="plane" size="0 0 1" contype="0" conaffinity="1" '
                f'friction="{ground:.17g} 0 0"/>'
            ]
            if collide
            else []
        ),  # fmt: skip
        *_body_xml(tree, 1, 2),
        "  </worldbody>",
        *(_motors(model) if motors else []),
        "</mujoco>",
    ]
    return "\n".join(lines) + "\n"


def _motors(model) -> list[str]:
    """The ``<actuator>`` block: a motor per hinge, three per ball joint (gear on its x, y, z
    axes), named after the joint (a ball joint's ``_x``, ``_y``, ``_z``)."""
    lines = ["  <actuator>"]
    for j in range(2, model.njoints):
        name = model.names[j]
        if model.joints[j].shortname() == "JointModelSpherical":
            for axis, gear in (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")):
                lines.append(f"    <motor name={quoteattr(f'{name}_{axis}')} "
                             f'joint={quoteattr(name)} gear="{gear}"/>')  # fmt: skip
        elif model.joints[j].nv == 1:
            lines.append(f"    <motor name={quoteattr(name)} joint={quoteattr(name)}/>")
    return [*lines, "  </actuator>"]


def _geom_xml(g) -> list[str]:
    shape = g.geometry
    kind = type(shape).__name__
    pos = _fmt(g.placement.translation)
    quat = _fmt(_quat_wxyz(g.placement.rotation))
    if kind == "Box":
        size = _fmt(np.asarray(shape.halfSide))
        return [f'<geom type="box" size="{size}" pos="{pos}" quat="{quat}"/>']
    if kind == "Sphere":
        return [f'<geom type="sphere" size="{shape.radius:.17g}" pos="{pos}" quat="{quat}"/>']
    if kind == "Cylinder":
        return [f'<geom type="cylinder" size="{shape.radius:.17g} {shape.halfLength:.17g}" '
                f'pos="{pos}" quat="{quat}"/>']  # fmt: skip
    return []  # meshes are left out: MuJoCo only needs them for looks here


def write_mjcf(h, path, mu: float | None = 0.8, timestep: float = 1e-3,
               integrator: str = "Euler", damping: float = 0.0) -> Path:  # fmt: skip
    """Write the body as a MuJoCo model to simulate (see the module docstring): a floor with
    friction ``mu`` (None: none), limits on, a motor per degree of freedom, MuJoCo's
    semi-implicit Euler (``integrator``) at ``timestep`` [s], joint ``damping`` [N m s/rad].

    Raises:
        ModelError: a friction, timestep or damping that is not a finite number in range."""
    if mu is not None and not (math.isfinite(mu) and mu >= 0.0):
        raise ModelError(f"the floor's friction must be a number >= 0, got {mu}")
    if not (math.isfinite(timestep) and 0.0 < timestep <= 0.1):
        raise ModelError(f"MuJoCo's timestep must be in (0, 0.1] s, got {timestep}")
    if not (math.isfinite(damping) and damping >= 0.0):
        raise ModelError(f"joint damping must be a number >= 0, got {damping}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = to_mjcf(h, timestep=timestep, integrator=integrator, ground=mu, limits=True,
                   damping=damping, motors=True)  # fmt: skip
    path.write_text(text, encoding="utf-8")
    return path


class StateMap:
    """Maps states (and generalised forces, which map like velocities) between a Humanoid and
    its exported MuJoCo model; the joint layout is looked up once."""

    def __init__(self, h, mj_model) -> None:
        import mujoco

        model = h.model
        self.nq, self.nv = model.nq, model.nv
        self.mj_nq, self.mj_nv = mj_model.nq, mj_model.nv
        self.layout = []  # per joint: (pin idx_q, idx_v, MuJoCo qposadr, dofadr, kind)
        for j in range(1, model.njoints):
            jm = model.joints[j]
            mid = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_JOINT, model.names[j])
            if mid < 0:
                raise ModelError(f"joint {model.names[j]} is not in the MuJoCo model")
            self.layout.append((jm.idx_q, jm.idx_v, mj_model.jnt_qposadr[mid],
                                mj_model.jnt_dofadr[mid], jm.shortname()))  # fmt: skip

    def to_mujoco(self, q, v):
        """(qpos, qvel) of MuJoCo for a Pinocchio state (q, v)."""
        qpos, qvel = np.zeros(self.mj_nq), np.zeros(self.mj_nv)
        for iq, iv, aq, av, kind in self.layout:
            if kind == "JointModelFreeFlyer":
                R = pin.Quaternion(q[iq + 3 : iq + 7]).toRotationMatrix()
                qpos[aq : aq + 3] = q[iq : iq + 3]
                qpos[aq + 3 : aq + 7] = np.roll(q[iq + 3 : iq + 7], 1)
                qvel[av : av + 3] = R @ v[iv : iv + 3]
                qvel[av + 3 : av + 6] = v[iv + 3 : iv + 6]
            elif kind == "JointModelSpherical":
                qpos[aq : aq + 4] = np.roll(q[iq : iq + 4], 1)
                qvel[av : av + 3] = v[iv : iv + 3]
            else:
                qpos[aq], qvel[av] = q[iq], v[iv]
        return qpos, qvel

    def to_pinocchio(self, qpos, qvel):
        """(q, v) of Pinocchio for a MuJoCo state."""
        q, v = np.zeros(self.nq), np.zeros(self.nv)
        for iq, iv, aq, av, kind in self.layout:
            if kind == "JointModelFreeFlyer":
                q[iq : iq + 3] = qpos[aq : aq + 3]
                q[iq + 3 : iq + 7] = np.roll(qpos[aq + 3 : aq + 7], -1)
                R = pin.Quaternion(q[iq + 3 : iq + 7]).toRotationMatrix()
                v[iv : iv + 3] = R.T @ qvel[av : av + 3]
                v[iv + 3 : iv + 6] = qvel[av + 3 : av + 6]
            elif kind == "JointModelSpherical":
                q[iq : iq + 4] = np.roll(qpos[aq : aq + 4], -1)
                v[iv : iv + 3] = qvel[av : av + 3]
            else:
                q[iq], v[iv] = qpos[aq], qvel[av]
        return q, v


def mujoco_state(h, mj_model, q, v):
    """(qpos, qvel) of MuJoCo for a Pinocchio state (q, v) (see :class:`StateMap`)."""
    return StateMap(h, mj_model).to_mujoco(q, v)


def pinocchio_state(h, mj_model, qpos, qvel):
    """(q, v) of Pinocchio for a MuJoCo state (see :class:`StateMap`)."""
    return StateMap(h, mj_model).to_pinocchio(qpos, qvel)
