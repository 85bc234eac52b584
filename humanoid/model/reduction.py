"""Joints taken out of a loaded model: those that move no mass (:func:`massless_joints`) and
those the caller locks (:func:`locked_joints`), their links merged into their parents; and
configurations carried over to the reduced model (:func:`restrict_configurations`)."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

from ..errors import ModelError
from .humanoid import Humanoid, child_link, upright

__all__ = ["MASSLESS_TOLERANCE", "locked_joints", "massless_joints", "restrict_configurations"]

# A joint whose diagonal block of M is below this (relative to the largest diagonal entry of M)
# moves no inertia: nothing resists its acceleration, and M is singular.
MASSLESS_TOLERANCE = 1e-12


def massless_joints(model: pin.Model, geoms, mode: str, label: str):
    """Find the joints whose motion moves no inertia (their diagonal block of M at the upright
    configuration is zero); raise, or lock them (``pin.buildReducedModel``)."""
    if model.nv == 0:
        return model, geoms
    q = upright(model)
    M = pin.crba(model, model.createData(), q)  # both triangles (tests/test_dynamics.py)
    scale = max(float(np.abs(np.diag(M)).max()), 1e-300)
    if M[:3, :3].trace() <= MASSLESS_TOLERANCE * scale or not np.isfinite(scale):
        raise ModelError(f"{label}: the body has no mass (no link has an <inertial>)")
    bad = []
    for j in range(2, model.njoints):
        jm = model.joints[j]
        block = M[jm.idx_v : jm.idx_v + jm.nv, jm.idx_v : jm.idx_v + jm.nv]
        if np.linalg.eigvalsh(block).min() <= MASSLESS_TOLERANCE * scale:
            bad.append(j)
    if not bad:
        return model, geoms
    if mode == "error":
        links = [child_link(model, j) for j in bad]
        raise ModelError(
            f"{label}: {len(bad)} joints move no mass (their links and everything after them "
            f"are massless, so M(q) is singular): {', '.join(model.names[j] for j in bad)} "
            f"(links {', '.join(links)}); give those links mass, or load with "
            "massless='merge' (CLI: --massless merge) to lock them into their parents"
        )
    return _reduced(model, geoms, bad, q)


def _reduced(model: pin.Model, geoms, joints, q):
    """``pin.buildReducedModel`` with every frame's parent frame kept valid."""
    reduced, geoms = pin.buildReducedModel(model, list(geoms), joints, q)
    for fid, f in enumerate(reduced.frames):
        if fid and f.parentFrame == fid:  # a locked joint's frame names itself as its parent
            joint = reduced.names[f.parentJoint]
            f.parentFrame = reduced.getFrameId(joint, pin.FrameType.JOINT) if f.parentJoint else 0
            reduced.frames[fid] = f
    return reduced, list(geoms)


def locked_joints(model: pin.Model, geoms, names, label: str):
    """The model with the named hinges locked at their upright value (:func:`load`'s
    ``lock``), the collision boxes a locked joint's link brings to its parent merged with the
    parent's into their bounding box (a foot with its toes locked has one sole box: the ground
    meets the corners of one sole, not two boxes' shared edge twice)."""
    if not names:
        return model, geoms
    ids = []
    for name in names:
        if not isinstance(name, str) or not model.existJointName(name):
            raise ModelError(f"{label}: cannot lock {name!r}: the body has no joint of that name")
        j = model.getJointId(name)
        if model.joints[j].nv != 1 or j < 2:
            raise ModelError(f"{label}: cannot lock {name!r}: only hinges are locked")
        ids.append(j)
    parents = {model.names[model.parents[j]] for j in ids}
    reduced, geoms = _reduced(model, geoms, sorted(set(ids)), upright(model))
    for name in parents:
        if reduced.existJointName(name):
            _merge_boxes(geoms[1], reduced.getJointId(name))
    return reduced, geoms


def _merge_boxes(gm: pin.GeometryModel, joint: int) -> None:
    """The boxes on ``joint`` replaced by their bounding box (in the joint's frame, their
    placements axis-aligned), so that the ground meets the corners of one sole."""
    boxes = [g for g in gm.geometryObjects
             if g.parentJoint == joint and isinstance(g.geometry, coal.Box)]  # fmt: skip
    if len(boxes) < 2 or any(not np.allclose(np.abs(g.placement.rotation), np.eye(3))
                             for g in boxes):  # fmt: skip
        return
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for g in boxes:
        half = np.abs(g.placement.rotation) @ np.asarray(g.geometry.halfSide)
        lo = np.minimum(lo, g.placement.translation - half)
        hi = np.maximum(hi, g.placement.translation + half)
    merged = boxes[0].copy()
    merged.geometry = coal.Box(*(hi - lo))
    merged.placement = pin.SE3(np.eye(3), (lo + hi) / 2)
    for name in [g.name for g in boxes]:  # (the list's objects move as the vector shrinks)
        gm.removeGeometryObject(name)
    gm.addGeometryObject(merged)


def restrict_configurations(q: np.ndarray, source: Humanoid, target: Humanoid) -> np.ndarray:
    """Configurations of ``source`` (n, nq) as ``target``'s, joint by joint by name: the
    same body with hinges locked (:func:`lock_foot_hinges`) drops theirs."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    out = np.tile(target.standing_configuration(), (len(q), 1))
    sm, tm = source.model, target.model
    for j in range(1, tm.njoints):
        name = tm.names[j]
        if not sm.existJointName(name):
            raise ModelError(f"cannot map {source.source}'s configurations: no joint {name!r}")
        js, jt = sm.joints[sm.getJointId(name)], tm.joints[j]
        out[:, jt.idx_q : jt.idx_q + jt.nq] = q[:, js.idx_q : js.idx_q + js.nq]
    return out
