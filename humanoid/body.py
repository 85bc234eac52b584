"""The de Leva body written as URDF, through yourdfpy's URDF objects.

Frames: world-aligned in the standing pose (x forward, y left, z up); every joint angle zero is
the upright anatomical pose with arms hanging and palms facing the thighs. The root link is the
``pelvis``, its origin at the midpoint of the hip joint centres (de Leva's MIDH).

Tree (35 joint DoF; 41 with the free-flyer root that :func:`humanoid.load` adds)::

    pelvis -lumbar(3)- abdomen -thoracic(3)- thorax -neck(3)- head
                                               thorax -{side}_shoulder(3)- {side}_upper_arm
                  -{side}_elbow- {side}_forearm -{side}_wrist(2)- {side}_hand
    pelvis -{side}_hip(3)- {side}_thigh -{side}_knee- {side}_shank -{side}_ankle(2)- {side}_foot
                                                                     -{side}_mtp- {side}_toes

Ball joints (hips, shoulders, lumbar, thoracic, neck) are three revolute joints through two
massless intermediate links, in the order flexion -> ab/adduction (lateral bending for the spine)
-> axial rotation, the ISB order (sagittal, frontal, transverse axes: y, x, z). Knees and elbows
are hinges. Ankles are two hinges (talocrural flexion about y, then subtalar inversion about x)
and wrists two hinges (flexion, then radial/ulnar deviation): a universal joint each, as in
example-robot-data's human and MuJoCo's humanoid.

Signs are anatomical: a positive angle is flexion, adduction, internal rotation, dorsiflexion,
inversion, radial deviation, on both sides (the axes of the right side are the mirror images of
the left ones), so that left and right share their limits. The spine and neck bend positively to
the left and rotate positively to the left.

By default each foot is a rearfoot and a toes segment on a ``{side}_mtp`` hinge (35 joint DoF;
see :func:`_foot_with_toes`). With ``BodyParameters(..., toes=False)`` each foot is one piece
(33 joint DoF): a collision box (the sole box, from the sole to the ankle height), a fixed
``{side}_sole`` frame at the centre of the sole, and four fixed contact points at the sole's
corners: ``{side}_heel_inner``, ``{side}_heel_outer``, ``{side}_toe_inner``, ``{side}_toe_outer``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np
from lxml import etree

from .anthropometry import (
    HEEL_TO_ANKLE_FRACTION,
    JOINT_RANGES,
    SIDES,
    BodyParameters,
    JointRange,
    Segment,
    body_dimensions,
    segments,
    split_foot,
)

__all__ = ["JOINT_RANGES", "SIDES", "build_urdf", "contact_point_names", "write_urdf"]

CONTACT_CORNERS = ("heel_inner", "heel_outer", "toe_inner", "toe_outer")
TISSUE_DENSITY = 1050.0  # [kg/m^3] used only to size the visual primitives


# fmt: off
# Left-side joint axes for a positive anatomical angle; the right side mirrors them.
# Peak torque [N m] for a 75 kg adult (scaled with body mass) and peak speed [rad/s]: the order
# of magnitude of example-robot-data's human.urdf limits (effort 20-190 N m, velocity 2-18.6).
AXES = MappingProxyType({
    #                      axis (left)      effort  velocity
    "hip_flexion":        ((0.0, -1.0, 0.0), 180.0, 12.0),
    "hip_adduction":      ((-1.0, 0.0, 0.0), 120.0, 12.0),
    "hip_rotation":       ((0.0, 0.0, -1.0), 60.0, 12.0),
    "knee":               ((0.0, 1.0, 0.0), 200.0, 18.0),
    "ankle_flexion":      ((0.0, -1.0, 0.0), 150.0, 12.0),
    "ankle_inversion":    ((-1.0, 0.0, 0.0), 40.0, 8.0),
    "lumbar_flexion":     ((0.0, 1.0, 0.0), 200.0, 5.0),
    "lumbar_bending":     ((-1.0, 0.0, 0.0), 160.0, 5.0),
    "lumbar_rotation":    ((0.0, 0.0, 1.0), 100.0, 5.0),
    "thoracic_flexion":   ((0.0, 1.0, 0.0), 190.0, 5.0),
    "thoracic_bending":   ((-1.0, 0.0, 0.0), 160.0, 5.0),
    "thoracic_rotation":  ((0.0, 0.0, 1.0), 100.0, 5.0),
    "neck_flexion":       ((0.0, 1.0, 0.0), 50.0, 8.0),
    "neck_bending":       ((-1.0, 0.0, 0.0), 40.0, 8.0),
    "neck_rotation":      ((0.0, 0.0, 1.0), 30.0, 8.0),
    "shoulder_flexion":   ((0.0, -1.0, 0.0), 90.0, 15.0),
    "shoulder_abduction": ((1.0, 0.0, 0.0), 80.0, 15.0),
    "shoulder_rotation":  ((0.0, 0.0, -1.0), 50.0, 15.0),
    "elbow":              ((0.0, -1.0, 0.0), 70.0, 18.0),
    "wrist_flexion":      ((-1.0, 0.0, 0.0), 20.0, 15.0),
    "wrist_deviation":    ((0.0, -1.0, 0.0), 20.0, 15.0),
    "mtp":                ((0.0, -1.0, 0.0), 30.0, 15.0),
})


@dataclass(frozen=True)
class PassiveJoint:
    """A joint's passive torque -stiffness q - damping dq [N m/rad, N m s/rad] for a 75 kg
    adult (scaled with body mass, as the efforts are)."""

    stiffness: float
    damping: float
    source: str


# FALISSE2022: Falisse, Afschrift & De Groote 2022, PLoS One 17:e0256311, "Modeling toes
# contributes to realistic stance knee mechanics in three-dimensional predictive simulations of
# walking": a linear passive MTP torque, 25 N m/rad and 2 N m s/rad (their code, predictsim_mtp:
# stiffnessMtp = 25; dampingMtp 1.9 plus 0.1 from the limit torque's damping).
PASSIVE_JOINTS = MappingProxyType({
    "mtp": PassiveJoint(25.0, 2.0, "FALISSE2022: stiffness 25 N m/rad, damping 2 N m s/rad"),
})
# fmt: on

BALL_JOINTS = MappingProxyType(
    {
        "hip": ("flexion", "adduction", "rotation"),
        "shoulder": ("flexion", "abduction", "rotation"),
        "lumbar": ("flexion", "bending", "rotation"),
        "thoracic": ("flexion", "bending", "rotation"),
        "neck": ("flexion", "bending", "rotation"),
    }
)

COLORS = MappingProxyType(
    {
        "skin": (0.87, 0.72, 0.60, 1.0),
        "trunk": (0.30, 0.45, 0.70, 1.0),
        "legs": (0.25, 0.25, 0.30, 1.0),
        "feet": (0.55, 0.30, 0.20, 1.0),
    }
)


def _urdf():
    """yourdfpy, imported on first use (it pulls in trimesh: half a second at import)."""
    import yourdfpy

    return yourdfpy


def contact_point_names(side: str) -> tuple[str, ...]:
    """Names of the four sole contact frames of one foot (``side`` is left or right)."""
    return tuple(f"{side}_{corner}" for corner in CONTACT_CORNERS)


def _mirror(v, side: str) -> np.ndarray:
    """A point (polar vector) of the left side reflected to ``side`` through the y = 0 plane."""
    v = np.asarray(v, dtype=float)
    return v * np.array([1.0, -1.0, 1.0]) if side == "right" else v


def _mirror_axis(axis, side: str) -> np.ndarray:
    """A rotation axis (axial vector) of the left side reflected to ``side``."""
    a = np.asarray(axis, dtype=float)
    return a * np.array([-1.0, 1.0, -1.0]) if side == "right" else a


def _pose(xyz) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


class _Builder:
    """Collects yourdfpy links and joints for one body."""

    def __init__(self, params: BodyParameters) -> None:
        self.params = params
        self.mass_scale = params.mass / 75.0
        self.links: list = []  # yourdfpy Links
        self.joints: list = []  # yourdfpy Joints
        self.materials = [
            _urdf().Material(name=k, color=_urdf().Color(rgba=np.array(c)))
            for k, c in COLORS.items()
        ]

    def link(
        self, name, segment: Segment | None = None, com=None, visuals=(), collisions=(), mass=None
    ):
        """A link; its collision geometry is its visual geometry unless given (the feet give
        their sole boxes), so that every segment can touch the ground. ``mass`` = (mass,
        3x3 inertia about the CoM) instead of a segment's."""
        if not collisions:
            collisions = [
                _urdf().Collision(name=v.name, origin=v.origin, geometry=v.geometry)
                for v in visuals
            ]
        inertial = None
        if segment is not None:
            mass = (segment.mass, np.diag(segment.inertia))
        if mass is not None:
            inertial = _urdf().Inertial(origin=_pose(com), mass=mass[0], inertia=mass[1])
        self.links.append(
            _urdf().Link(
                name=name, inertial=inertial, visuals=list(visuals), collisions=list(collisions)
            )
        )

    def revolute(self, name, kind, side, parent, child, xyz):
        axis, effort, velocity = AXES[kind]
        own = self.params.ranges  # the subject's, by joint, then by kind
        rng = JOINT_RANGES[kind]
        if name in own or kind in own:
            lower, upper = own.get(name, own.get(kind))
            rng = JointRange(lower, upper, "the subject's")
        passive = PASSIVE_JOINTS.get(kind)
        dynamics = None
        if passive is not None:  # the damping in the URDF; the stiffness in PASSIVE_JOINTS
            dynamics = _urdf().Dynamics(damping=passive.damping * self.mass_scale, friction=0.0)
        self.joints.append(
            _urdf().Joint(
                name=name,
                type="revolute",
                parent=parent,
                child=child,
                origin=_pose(xyz),
                axis=_mirror_axis(axis, side),
                limit=_urdf().Limit(
                    effort=effort * self.mass_scale,
                    velocity=velocity,
                    lower=math.radians(rng.lower),
                    upper=math.radians(rng.upper),
                ),
                dynamics=dynamics,
            )
        )

    def fixed(self, name, parent, child, xyz):
        self.joints.append(
            _urdf().Joint(name=name, type="fixed", parent=parent, child=child, origin=_pose(xyz))
        )

    def ball(self, prefix, kind, side, parent, child, xyz):
        """Three revolute joints through two massless links: ``{prefix}_{motion}``."""
        motions = BALL_JOINTS[kind]
        chain = [parent] + [f"{prefix}_{m}_link" for m in motions[:2]] + [child]
        for i, motion in enumerate(motions):
            if i < 2:
                self.link(chain[i + 1])
            self.revolute(
                f"{prefix}_{motion}",
                f"{kind}_{motion}",
                side,
                chain[i],
                chain[i + 1],
                xyz if i == 0 else (0.0, 0.0, 0.0),
            )

    def build(self):
        robot = _urdf().Robot(
            name="humanoid_" + self.params.sex,
            links=self.links,
            joints=self.joints,
            materials=self.materials,
        )
        return _urdf().URDF(robot=robot, build_scene_graph=False, load_meshes=False)


def _visual(name, shape, xyz, material, collision=False):
    geometry = _urdf().Geometry(**shape)
    cls = _urdf().Collision if collision else _urdf().Visual
    kwargs = {} if collision else {"material": _urdf().Material(name=material)}
    return cls(name=name, origin=_pose(xyz), geometry=geometry, **kwargs)


def _cylinder(length, mass):
    radius = math.sqrt(mass / (TISSUE_DENSITY * math.pi * length))
    return {"cylinder": _urdf().Cylinder(radius=radius, length=length)}


def _box(x, y, z):
    return {"box": _urdf().Box(size=np.array([x, y, z]))}


def _trunk_box(seg: Segment, width):
    depth = seg.mass / (TISSUE_DENSITY * width * seg.length)
    return _box(depth, width, seg.length)


def build_urdf_object(params: BodyParameters):
    """The body as a yourdfpy ``URDF`` object (see the module docstring for its layout)."""
    seg = segments(params)
    d = body_dimensions(params)
    b = _Builder(params)

    # Trunk: each segment's frame at its lower joint, CoM measured from its upper landmark.
    def up(name):
        s = seg[name]
        return (0.0, 0.0, s.length * (1.0 - s.com_fraction))

    pelvis, abdomen, thorax, head = (seg[k] for k in ("pelvis", "abdomen", "thorax", "head"))
    hip_w, shoulder_w = d["hip_width"], d["shoulder_width"]
    b.link(
        "pelvis",
        pelvis,
        up("pelvis"),
        [_visual("pelvis", _trunk_box(pelvis, hip_w), (0, 0, pelvis.length / 2), "trunk")],
    )
    b.ball("lumbar", "lumbar", "left", "pelvis", "abdomen", (0.0, 0.0, pelvis.length))
    b.link(
        "abdomen",
        abdomen,
        up("abdomen"),
        [_visual("abdomen", _trunk_box(abdomen, hip_w), (0, 0, abdomen.length / 2), "trunk")],
    )
    b.ball("thoracic", "thoracic", "left", "abdomen", "thorax", (0.0, 0.0, abdomen.length))
    b.link(
        "thorax",
        thorax,
        up("thorax"),
        [
            _visual(
                "thorax",
                _trunk_box(thorax, 0.8 * shoulder_w),
                (0, 0, thorax.length / 2),
                "trunk",
            )
        ],
    )
    b.ball("neck", "neck", "left", "thorax", "head", (0.0, 0.0, thorax.length))
    # A sphere of the head's volume whose top is the vertex, on a neck cylinder from C7.
    head_r = min(
        (3.0 * head.mass / (4.0 * math.pi * TISSUE_DENSITY)) ** (1.0 / 3.0), head.length / 2
    )
    neck_len = max(head.length - 2.0 * head_r, 0.01)
    b.link(
        "head",
        head,
        up("head"),
        [
            _visual(
                "head",
                {"sphere": _urdf().Sphere(radius=head_r)},
                (0, 0, head.length - head_r),
                "skin",
            ),
            _visual(
                "neck",
                {"cylinder": _urdf().Cylinder(radius=0.35 * head_r, length=neck_len)},
                (0, 0, neck_len / 2),
                "skin",
            ),
        ],
    )

    for side in SIDES:
        _arm(b, seg, d, side)
        _leg(b, seg, d, side)
    return b.build()


def _limb_link(b, name, s: Segment, material):
    """A limb segment hanging down from its proximal joint along -z."""
    b.link(
        name,
        s,
        (0.0, 0.0, -s.com_fraction * s.length),
        [_visual(name, _cylinder(s.length, s.mass), (0, 0, -s.length / 2), material)],
    )


def _arm(b: _Builder, seg, d, side):
    h = b.params.height
    thorax = seg["thorax"]
    f = d["shoulder_joint_forward"]
    shoulder = _mirror(
        (f, d["shoulder_joint_half_width"], thorax.length - d["shoulder_joint_below_c7"]), side
    )
    ua, fa, hand = seg["upper_arm"], seg["forearm"], seg["hand"]
    b.ball(f"{side}_shoulder", "shoulder", side, "thorax", f"{side}_upper_arm", shoulder)
    _limb_link(b, f"{side}_upper_arm", ua, "skin")
    b.revolute(
        f"{side}_elbow", "elbow", side, f"{side}_upper_arm", f"{side}_forearm", (0, 0, -ua.length)
    )
    _limb_link(b, f"{side}_forearm", fa, "skin")
    b.link(f"{side}_wrist_flexion_link")
    b.revolute(
        f"{side}_wrist_flexion",
        "wrist_flexion",
        side,
        f"{side}_forearm",
        f"{side}_wrist_flexion_link",
        (0, 0, -fa.length),
    )
    b.revolute(
        f"{side}_wrist_deviation",
        "wrist_deviation",
        side,
        f"{side}_wrist_flexion_link",
        f"{side}_hand",
        (0, 0, 0),
    )
    hand_width = 0.045 * h  # visual only: hand breadth about 0.045 x stature
    thickness = hand.mass / (TISSUE_DENSITY * hand_width * hand.length)
    b.link(
        f"{side}_hand",
        hand,
        (0.0, 0.0, -hand.com_fraction * hand.length),
        [
            _visual(
                f"{side}_hand",
                _box(hand_width, thickness, hand.length),
                (0, 0, -hand.length / 2),
                "skin",
            )
        ],
    )


def _leg(b: _Builder, seg, d, side):
    thigh, shank, foot = seg["thigh"], seg["shank"], seg["foot"]
    hip = _mirror((0.0, d["hip_joint_half_width"], 0.0), side)
    b.ball(f"{side}_hip", "hip", side, "pelvis", f"{side}_thigh", hip)
    _limb_link(b, f"{side}_thigh", thigh, "legs")
    b.revolute(
        f"{side}_knee", "knee", side, f"{side}_thigh", f"{side}_shank", (0, 0, -thigh.length)
    )
    _limb_link(b, f"{side}_shank", shank, "legs")
    b.link(f"{side}_ankle_flexion_link")
    b.revolute(
        f"{side}_ankle_flexion",
        "ankle_flexion",
        side,
        f"{side}_shank",
        f"{side}_ankle_flexion_link",
        (0, 0, -shank.length),
    )
    b.revolute(
        f"{side}_ankle_inversion",
        "ankle_inversion",
        side,
        f"{side}_ankle_flexion_link",
        f"{side}_foot",
        (0, 0, 0),
    )
    # Foot frame at the ankle joint centre; the sole lies ankle_height below it.
    length, width, ah = foot.length, d["foot_width"], d["ankle_height"]

    heel_x = -HEEL_TO_ANKLE_FRACTION * length
    if b.params.toes:
        _foot_with_toes(b, side, foot, width, ah, heel_x)
        return
    centre = (heel_x + length / 2, 0.0, -ah / 2)
    com = (heel_x + foot.com_fraction * length, 0.0, -ah / 2)
    b.link(
        f"{side}_foot",
        foot,
        com,
        visuals=[_visual(f"{side}_foot", _box(length, width, ah), centre, "feet")],
        collisions=[_visual(f"{side}_sole_box", _box(length, width, ah), centre, "", True)],
    )
    b.link(f"{side}_sole")
    b.fixed(f"{side}_sole_joint", f"{side}_foot", f"{side}_sole", (centre[0], 0.0, -ah))
    for corner, name in zip(CONTACT_CORNERS, contact_point_names(side), strict=True):
        x = heel_x if corner.startswith("heel") else heel_x + length
        y = -width / 2 if corner.endswith("inner") else width / 2
        b.link(name)
        b.fixed(f"{name}_joint", f"{side}_foot", name, _mirror((x, y, -ah), side))


def _foot_with_toes(b: _Builder, side, foot: Segment, width, ah, heel_x):
    """The rearfoot (heel to the metatarsal heads) and the toes on the ``{side}_mtp`` hinge.

    Contact frames: ``heel_inner|heel_outer`` on the rearfoot; ``meta_inner|meta_outer``
    (under the first and fifth metatarsal heads, the toes' rear corners, directly below the MTP
    axis) and ``toe_inner|toe_outer`` (the toe tip) on the toes, so that the rearfoot rolls
    over the metatarsal heads about the MTP axis while the toes lie flat; ``{side}_sole`` at
    the centre of the rearfoot's sole and ``{side}_toes_sole`` at the centre of the toes'. At
    an MTP angle of zero every frame is where the one-piece foot has it, and the two parts have
    the one-piece foot's mass, CoM and inertia.
    """
    parts = split_foot(foot, width, ah)
    sole_z = -ah  # in the foot frame (at the ankle joint centre)

    def at(x, z):  # a point given from the heel on the sole, in the foot frame
        return np.array([heel_x + x, 0.0, sole_z + z])

    rear_len, toes_len = parts.mtp_x, foot.length - parts.mtp_x
    rear_centre = at(rear_len / 2, ah / 2)
    b.link(
        f"{side}_foot",
        com=at(parts.rear_com[0], parts.rear_com[2]),
        mass=(parts.rear_mass, parts.rear_inertia),
        visuals=[_visual(f"{side}_foot", _box(rear_len, width, ah), rear_centre, "feet")],
        collisions=[_visual(f"{side}_sole_box", _box(rear_len, width, ah), rear_centre, "", True)],
    )
    joint = at(parts.mtp_x, parts.joint_z)  # the toes' frame sits on the MTP axis
    b.revolute(f"{side}_mtp", "mtp", side, f"{side}_foot", f"{side}_toes", joint)
    toes_centre = np.array([toes_len / 2, 0.0, parts.toes_height / 2 - parts.joint_z])
    toes_box = _box(toes_len, width, parts.toes_height)
    b.link(
        f"{side}_toes",
        com=parts.toes_com - np.array([parts.mtp_x, 0.0, parts.joint_z]),
        mass=(parts.toes_mass, parts.toes_inertia),
        visuals=[_visual(f"{side}_toes", toes_box, toes_centre, "feet")],
        collisions=[_visual(f"{side}_toes_box", toes_box, toes_centre, "", True)],
    )
    b.link(f"{side}_sole")
    b.fixed(f"{side}_sole_joint", f"{side}_foot", f"{side}_sole", at(rear_len / 2, 0.0))
    b.link(f"{side}_toes_sole")
    b.fixed(
        f"{side}_toes_sole_joint",
        f"{side}_toes",
        f"{side}_toes_sole",
        (toes_len / 2, 0.0, -parts.joint_z),
    )
    for part, x in (("heel", 0.0), ("meta", parts.mtp_x), ("toe", foot.length)):
        parent, origin = (f"{side}_foot", 0.0) if part == "heel" else (f"{side}_toes", joint)
        for edge, y in (("inner", -width / 2), ("outer", width / 2)):
            name = f"{side}_{part}_{edge}"
            b.link(name)
            xyz = at(x, 0.0) + np.array([0.0, y, 0.0]) - origin
            b.fixed(f"{name}_joint", parent, name, _mirror(xyz, side))


def build_urdf(params: BodyParameters) -> str:
    """URDF text of the body of a person.

    Args:
        params: The person (height, mass, sex, optional measured segment lengths).

    Returns:
        The URDF document as a string; it parses with yourdfpy and Pinocchio.
    """
    tree = build_urdf_object(params).write_xml()
    # yourdfpy's write_xml_string drops its keyword arguments (0.0.60), so format with lxml.
    text = etree.tostring(tree, pretty_print=True, encoding="unicode")
    lengths = "".join(f", {k} {v} m" for k, v in sorted(params.segment_lengths.items()))
    ranges = "".join(f", range {k} {a} {b} deg" for k, (a, b) in sorted(params.ranges.items()))
    return (
        '<?xml version="1.0"?>\n'
        f"<!-- humanoid body: height {params.height} m, mass {params.mass} kg, sex {params.sex}"
        f"{lengths}{', toes' if params.toes else ''}{ranges}. Segment parameters: de Leva (1996)"
        " Table 4. Written by humanoid.build_urdf."
        " -->\n" + text
    )


def write_urdf(params: BodyParameters, path: str | Path) -> Path:
    """Write :func:`build_urdf` to ``path`` (parent folders are created) and return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(build_urdf(params), encoding="ascii")
    return path
