"""The feet of a loaded model: found by name (:func:`find_feet`), the model turned so that it
stands along +Z on them (:func:`make_z_up`), and its sole frames and contact points
(:func:`add_sole_frames`)."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from .humanoid import SIDES, frame_hint, upright, world_box

__all__ = ["CORNERS", "FOOT_WORDS", "add_sole_frames", "find_feet", "make_z_up"]

CORNERS = ("heel_inner", "heel_outer", "toe_inner", "toe_outer")
FOOT_WORDS = ("sole", "foot", "ankle")


def _side_match(name: str, side: str) -> bool:
    n = name.lower()
    return side in n or re.search(rf"(^|[^a-z]){side[0]}([^a-z]|$)", n) is not None


def find_feet(model: pin.Model, feet, label: str) -> tuple[str, str]:
    if feet is not None:
        feet = tuple(feet)
        if len(feet) != 2:
            raise ModelError(f"feet must be two frame names (left, right), got {feet!r}")
        for name in feet:
            if not model.existFrame(name):
                raise ModelError(f"{label}: no frame {name!r}; {frame_hint(model)}")
        return feet
    found = []
    for side in SIDES:
        best = None
        for f in model.frames:
            n = f.name.lower()
            if "virtual" in n or not _side_match(n, side):
                continue
            other = SIDES[1 - SIDES.index(side)]
            if other in n:
                continue
            for rank, word in enumerate(FOOT_WORDS):
                if word in n:
                    # a toes segment's frames only where nothing else names the foot
                    toe = "toe" in n
                    key = (toe, rank, -f.parentJoint, f.type == pin.FrameType.JOINT, len(n))
                    if best is None or key < best[0]:
                        best = (key, f.name)
                    break
        if best is None:
            raise ModelError(
                f"{label}: cannot identify the {side} foot (no frame name with "
                f"{'/'.join(FOOT_WORDS)} and {side!r}); candidates (leaf links): "
                f"{', '.join(_leaf_links(model))}. Pass feet=(left, right)."
            )
        found.append(best[1])
    return tuple(found)


def _leaf_links(model: pin.Model) -> list[str]:
    parents = set(model.parents)
    leaves = {j for j in range(1, model.njoints) if j not in parents}
    return [
        f.name for f in model.frames if f.type == pin.FrameType.BODY and f.parentJoint in leaves
    ]


def make_z_up(model: pin.Model, geoms, feet: tuple[str, str]) -> None:
    """Turn the root link so that the direction from the feet to the pelvis is +Z.

    The turn goes between the free-flyer joint and the root link (into every placement and
    inertia carried by joint 1), so the free-flyer's coordinates stay world-aligned.
    """
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    up = data.oMi[1].translation - np.mean(
        [data.oMf[model.getFrameId(n)].translation for n in feet], axis=0
    )
    axis = int(np.argmax(np.abs(up)))
    turns = {  # rotation taking the URDF's up axis to +Z, keeping +X forward where possible
        (0, 1): pin.utils.rotate("y", -np.pi / 2),
        (0, -1): pin.utils.rotate("y", np.pi / 2),
        (1, 1): pin.utils.rotate("x", np.pi / 2),
        (1, -1): pin.utils.rotate("x", -np.pi / 2),
        (2, -1): pin.utils.rotate("x", np.pi),
    }
    R = turns.get((axis, int(np.sign(up[axis]))))
    if R is None:
        return
    T = pin.SE3(R, np.zeros(3))
    model.inertias[1] = model.inertias[1].se3Action(T)
    for j in range(2, model.njoints):
        if model.parents[j] == 1:
            model.jointPlacements[j] = T * model.jointPlacements[j]
    for f in model.frames:
        if f.parentJoint == 1 and f.type != pin.FrameType.JOINT:
            f.placement = T * f.placement
    for gm in geoms:
        for g in gm.geometryObjects:
            if g.parentJoint == 1:
                g.placement = T * g.placement


def add_sole_frames(model: pin.Model, geoms, feet):
    """Sole frames and contact points: the model's own, or from the foot geometry's box."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, upright(model))
    soles, contacts = [], {}
    for side, foot in zip(SIDES, feet, strict=True):
        names = tuple(f"{side}_{c}" for c in CORNERS)
        fid = model.getFrameId(foot)
        joint = model.frames[fid].parentJoint
        if all(model.existFrame(n) for n in names):
            contacts[side] = names
            sole = foot if "sole" in foot.lower() else f"{side}_sole"
            if not model.existFrame(sole):
                sole = foot
            soles.append(sole)
            continue
        box = _foot_box(model, data, geoms, joint)
        if box is None:  # no contact points: fine until a scene or a walk asks for contacts
            contacts[side] = ()
            soles.append(foot)
            continue
        lo, hi = box
        inner_y = lo[1] if side == "left" else hi[1]
        outer_y = hi[1] if side == "left" else lo[1]
        oMi = data.oMi[joint]
        R_local = oMi.rotation.T  # world-aligned in the standing pose
        points = {
            "heel_inner": (lo[0], inner_y),
            "heel_outer": (lo[0], outer_y),
            "toe_inner": (hi[0], inner_y),
            "toe_outer": (hi[0], outer_y),
        }
        for corner, (x, y) in points.items():
            p = oMi.actInv(np.array([x, y, lo[2]]))
            model.addFrame(
                pin.Frame(
                    f"{side}_{corner}", joint, fid, pin.SE3(R_local, p), pin.FrameType.OP_FRAME
                ),
                False,
            )
        contacts[side] = names
        if "sole" in foot.lower():
            soles.append(foot)
        else:
            centre = oMi.actInv(np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]]))
            sole = f"{side}_sole"
            model.addFrame(
                pin.Frame(sole, joint, fid, pin.SE3(R_local, centre), pin.FrameType.OP_FRAME), False
            )
            soles.append(sole)
    return tuple(soles), contacts


def _foot_box(model, data, geoms, joint):
    """World bounding box of the foot's geometry: collision geometry first, visual otherwise
    (None if the foot has none)."""
    for gm in (geoms[1], geoms[0]):
        box = world_box(model, data, gm, {joint})
        if box is not None:
            return box
    return None
