"""The checks of a URDF before Pinocchio reads it (:func:`validate_urdf`: its parser crashes
on cycles, and urdfdom drops what it cannot read without a word) and of what Pinocchio built
from it (:func:`check_built`)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from ..errors import ModelError

__all__ = ["JOINT_TYPES", "LINK_TAGS", "URDF_MAX_BYTES", "UnknownTagWarning", "check_built",
           "validate_urdf"]  # fmt: skip

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
URDF_MAX_BYTES = 64 * 2**20  # a humanoid's URDF is kilobytes; larger is not a body


def _numbers(element, attribute: str, n: int, where: str, default: str | None = None):
    """An attribute of n finite numbers separated by spaces (urdfdom silently drops the whole
    <inertial> of an origin written with commas, or with inf, or with two numbers)."""
    text = element.get(attribute, default)
    if text is None:
        raise ModelError(f"{where}: <{element.tag}> needs {attribute}=")
    try:
        x = [float(s) for s in text.split()]
    except ValueError:
        x = []
    if len(x) != n or not all(math.isfinite(a) for a in x):
        raise ModelError(
            f"{where}: <{element.tag} {attribute}={text!r}> must be {n} finite number(s) "
            "separated by spaces"
        )
    return np.array(x)


def _origin(element, where: str) -> pin.SE3:
    """The <origin> child of an element as an SE3 (identity if absent)."""
    o = element.find("origin")
    if o is None:
        return pin.SE3.Identity()
    xyz = _numbers(o, "xyz", 3, where, "0 0 0")
    rpy = _numbers(o, "rpy", 3, where, "0 0 0")
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), xyz)


LINK_TAGS = ("inertial", "visual", "collision")  # a <link>'s children (the URDF spec)


class UnknownTagWarning(UserWarning):
    """A URDF element the toolkit does not read (a simulator's extension), left out."""


def _check_link_tags(link, where: str) -> None:
    """Refuse a <link> child that is a misspelt :data:`LINK_TAGS` (``<intertial>``: urdfdom
    skips it, and the link loses its mass without a word) with ModelError naming the link and
    the tag; warn (:class:`UnknownTagWarning`) about any other unknown child."""
    import difflib

    for child in link:
        if not isinstance(child.tag, str) or child.tag in LINK_TAGS:
            continue  # (comments)
        near = difflib.get_close_matches(child.tag.lower(), LINK_TAGS, n=1, cutoff=0.75)
        if near:
            raise ModelError(
                f"{where}: unknown element <{child.tag}>: did you mean <{near[0]}>? (a URDF "
                "reader skips it: the link would lose it)"
            )
        warnings.warn(f"{where}: element <{child.tag}> is not URDF's (inertial, visual, "
                      "collision): left out", UnknownTagWarning, stacklevel=4)  # fmt: skip


def validate_urdf(text: str, label: str, path: Path | None, dirs: list[str]) -> dict:
    """Check a URDF before Pinocchio sees it (its parser crashes on cycles, and urdfdom
    drops what it cannot read without a word). Returns each link's declared inertia
    (``pin.Inertia`` in the link frame), for :func:`check_built`."""
    if len(text) > URDF_MAX_BYTES:
        raise ModelError(f"{label}: {len(text)} bytes is too large for a URDF")
    try:
        root = etree.fromstring(text.encode("utf-8"))
    except (etree.XMLSyntaxError, ValueError) as exc:
        raise ModelError(f"{label}: malformed URDF XML: {exc}") from None
    if root.tag != "robot":
        raise ModelError(f"{label}: the root element is <{root.tag}>, expected <robot>")
    _check_tree(root, label)
    for color in root.iter("color"):
        owner = next((a.get("name") for a in color.iterancestors("material")), "?")
        rgba = _numbers(color, "rgba", 4, f"{label}: material {owner!r}")
        if np.any(rgba < 0) or np.any(rgba > 1):
            raise ModelError(f"{label}: material {owner!r}: rgba must be in [0, 1], got {rgba}")
    declared = {}
    for link in root.iter("link"):
        name = link.get("name", "?")
        where = f"{label}: link {name!r}"
        _check_link_tags(link, where)
        for kind in ("visual", "collision"):
            for g in link.iter(kind):
                _origin(g, f"{where} <{kind}>")
                _check_shape(g, f"{where} <{kind}>")
        inertial = link.find("inertial")
        if inertial is None:
            declared[name] = pin.Inertia.Zero()
            continue
        placement = _origin(inertial, f"{where} <inertial>")
        try:
            mass = float(inertial.find("mass").get("value"))
            I = inertial.find("inertia")
            v = {k: float(I.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        except (AttributeError, TypeError, ValueError):
            raise ModelError(f"{where}: <inertial> needs <mass value> and <inertia>") from None
        if not math.isfinite(mass) or mass < 0 or mass > 1e9:
            raise ModelError(f"{where}: mass must be finite, >= 0 and <= 1e9 kg, got {mass}")
        M = np.array(
            [
                [v["ixx"], v["ixy"], v["ixz"]],
                [v["ixy"], v["iyy"], v["iyz"]],
                [v["ixz"], v["iyz"], v["izz"]],
            ]
        )
        if not np.all(np.isfinite(M)) or np.abs(M).max() > 1e12:
            raise ModelError(f"{where}: inertia has non-finite or absurd (> 1e12) entries")
        eig = np.linalg.eigvalsh(M)
        if eig[0] < -1e-9 * max(1.0, abs(eig[-1])):
            raise ModelError(
                f"{where}: inertia is not positive semi-definite (eigenvalues {eig.round(9)})"
            )
        if eig[0] < 0.0:  # (within rounding, above: icub's r_hip_2 prints -5.4e-20)
            w, V = np.linalg.eigh(M)
            M = (V * np.maximum(w, 0.0)) @ V.T
        R = placement.rotation
        try:
            declared[name] = pin.Inertia(mass, placement.translation, R @ M @ R.T)
        except RuntimeError as exc:  # (Pinocchio's own checks, should ours miss one)
            raise ModelError(f"{where}: Pinocchio refuses its inertia: {exc}") from None
    for mesh in root.iter("mesh"):
        filename = mesh.get("filename", "")
        if _resolve_mesh(filename, path, dirs) is None:
            owner = next((a.get("name") for a in mesh.iterancestors("link")), "?")
            raise ModelError(
                f"{label}: link {owner!r}: mesh {filename!r} not found "
                f"(searched {', '.join(dirs) or 'no package folders'})"
            )

    return declared


def _check_tree(root, label: str) -> None:
    """Links and joints form one tree: unique names, known joint types, every joint between
    two existing and different links, each link with at most one parent, one root, no cycle."""
    links = [link.get("name") for link in root.findall("link")]
    if not links:
        raise ModelError(f"{label}: no <link>")
    if None in links:
        raise ModelError(f"{label}: a <link> has no name")
    dup = sorted({n for n in links if links.count(n) > 1})
    if dup:
        raise ModelError(f"{label}: links defined twice: {', '.join(dup)}")
    known, names = set(links), set()
    parent: dict[str, str] = {}
    children: dict[str, list[str]] = {}
    for joint in root.findall("joint"):
        name = joint.get("name")
        where = f"{label}: joint {name!r}"
        if name is None or name in names:
            raise ModelError(f"{where}: a joint needs a unique name")
        names.add(name)
        kind = joint.get("type")
        if kind not in JOINT_TYPES:
            raise ModelError(f"{where}: type {kind!r} is not one of {', '.join(JOINT_TYPES)}")
        ends: list[str] = []
        for end in ("parent", "child"):
            e = joint.find(end)
            link = e.get("link") if e is not None else None
            if link is None or link not in known:  # (no link is None: checked above)
                raise ModelError(f"{where}: <{end} link={link!r}> is not a link of the file")
            ends.append(link)
        p, c = ends
        if p == c:
            raise ModelError(f"{where}: parent and child are the same link {p!r}")
        if c in parent:
            raise ModelError(f"{where}: link {c!r} already has the parent {parent[c]!r}")
        parent[c] = p
        children.setdefault(p, []).append(c)
        _origin(joint, where)
        if kind in ("revolute", "continuous", "prismatic", "planar"):
            axis = joint.find("axis")
            if axis is not None and not np.any(_numbers(axis, "xyz", 3, where, "1 0 0")):
                raise ModelError(f"{where}: <axis xyz> is zero")
        dynamics = joint.find("dynamics")
        if dynamics is not None:
            for key in ("damping", "friction"):
                if dynamics.get(key) is not None:
                    _numbers(dynamics, key, 1, where)
        limit = joint.find("limit")
        if kind in ("revolute", "prismatic") and limit is None:
            raise ModelError(f"{where}: a {kind} joint needs <limit>")
        if limit is not None:
            for key in ("lower", "upper", "effort", "velocity"):
                if limit.get(key) is not None:
                    _numbers(limit, key, 1, where)
    roots = [n for n in links if n not in parent]
    if len(roots) != 1:
        raise ModelError(
            f"{label}: the links must form one tree with one root; roots: "
            f"{', '.join(roots) or 'none (a cycle)'}"
        )
    seen, stack = set(), [roots[0]]
    while stack:
        n = stack.pop()
        seen.add(n)
        stack.extend(children.get(n, []))
    if len(seen) != len(links):
        cut = sorted(known - seen)
        raise ModelError(f"{label}: links in a cycle, not reachable from {roots[0]!r}: "
                         f"{', '.join(cut)}")  # fmt: skip


def _check_shape(element, where: str) -> None:
    """A visual or collision geometry's sizes: finite and positive."""
    g = element.find("geometry")
    if g is None or len(g) == 0:
        raise ModelError(f"{where}: needs a <geometry> with a shape")
    shape = g[0]
    sizes = {"box": [("size", 3)], "cylinder": [("radius", 1), ("length", 1)],
             "sphere": [("radius", 1)], "capsule": [("radius", 1), ("length", 1)]}  # fmt: skip
    for attribute, n in sizes.get(shape.tag, []):
        if np.any(_numbers(shape, attribute, n, where) <= 0):
            raise ModelError(f"{where}: <{shape.tag} {attribute}> must be positive")
    if shape.tag == "mesh" and shape.get("scale") is not None:
        _numbers(shape, "scale", 3, where)


def check_built(model: pin.Model, declared: dict, label: str) -> None:
    """What Pinocchio built equals what the URDF declares: each joint's inertia is the sum of
    its links' declared inertias (a link that urdfdom dropped would be missing)."""
    frames: dict[int, list] = {}
    for f in model.frames:
        if f.type == pin.FrameType.BODY:
            frames.setdefault(f.parentJoint, []).append(f)
    for j in range(1, model.njoints):
        expected = pin.Inertia.Zero()
        for f in frames.get(j, []):
            expected += f.placement.act(declared.get(f.name, pin.Inertia.Zero()))
        built = model.inertias[j]
        scale = max(1.0, float(np.abs(expected.matrix()).max()))
        if np.abs(built.matrix() - expected.matrix()).max() > 1e-6 * scale:
            names = ", ".join(f.name for f in frames.get(j, []))
            raise ModelError(
                f"{label}: link(s) {names}: Pinocchio built mass {built.mass:.6g} kg where the "
                f"URDF declares {expected.mass:.6g} kg (an element the URDF parser could not "
                "read was dropped)"
            )


def _resolve_mesh(filename: str, path: Path | None, dirs: list[str]) -> Path | None:
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        candidates = [Path(d) / rest for d in dirs]
    elif filename.startswith("file://"):
        candidates = [Path(filename[len("file://") :])]
    else:
        base = path.parent if path is not None else Path.cwd()
        candidates = [base / filename]
    return next((c for c in candidates if c.is_file()), None)
