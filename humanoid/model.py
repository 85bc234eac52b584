"""Load any humanoid URDF into Pinocchio with a free-flyer root: :func:`load`.

What loading does, in order:

1. Reads the URDF (a path, a string of XML, a shipped body's name such as ``"adult_male"``,
   or an example-robot-data robot's name such as ``"talos"``) and checks it before Pinocchio
   sees it: well-formed XML; one tree of links (no cycle, no link with two parents, no joint
   from a link to itself); known joint types; every origin, axis and size three finite numbers
   separated by spaces; finite non-negative masses and positive semi-definite inertias; mesh
   files that exist. After building, each joint's inertia must equal the sum of its links'
   declared inertias (urdfdom drops what it cannot read without a word). Each problem is a
   :class:`ModelError` naming the file and the element.
2. Builds the Pinocchio model with a ``JointModelFreeFlyer`` root at the URDF's root link (the
   pelvis of a human), and its visual and collision geometry.
3. Finds the feet by name (``sole`` before ``foot`` before ``ankle``, with ``left``/``l`` and
   ``right``/``r`` tokens; a toes segment's frames last) unless the caller names them.
4. Turns a model whose URDF is not Z-up (example-robot-data's human is Y-up, ISB) so that it
   stands along +Z: the free-flyer's joint placement gets the fixed rotation.
5. With ``ball_joints="quaternion"``, fuses hinge triplets into spherical joints
   (:mod:`humanoid.fusion`).
6. Adds, where the model has none, a ``{side}_sole`` frame at the centre of each sole and four
   sole contact points ``{side}_heel_inner|heel_outer|toe_inner|toe_outer``, from the
   bounding box of the foot's geometry (collision geometry first, visual otherwise).
7. Reads the named postures of an SRDF (its ``group_state`` s: example-robot-data's own SRDF
   for its robots, such as Talos's ``half_sitting``, or one the caller gives) into
   :attr:`Humanoid.postures`; :meth:`Humanoid.reference_configuration` stands the body in one.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
from lxml import etree

from .errors import ConfigurationError, ModelError, finite_vector
from .fusion import Fusion, fuse_ball_joints
from .variants import BALL_JOINTS, MASSLESS

__all__ = [
    "Humanoid",
    "child_link",
    "example_robot_names",
    "load",
    "load_example",
    "load_recipe",
    "lock_foot_hinges",
    "restrict_configurations",
]

SIDES = ("left", "right")
CORNERS = ("heel_inner", "heel_outer", "toe_inner", "toe_outer")
FOOT_WORDS = ("sole", "foot", "ankle")
# A joint whose diagonal block of M is below this (relative to the largest diagonal entry of M)
# moves no inertia: nothing resists its acceleration, and M is singular.
MASSLESS_TOLERANCE = 1e-12


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
            raise ModelError(f"no frame {name!r} in {self.source}; {_frame_hint(self.model)}")
        return self.model.getFrameId(name)

    def sole_id(self, side: str) -> int:
        """Index of a side's sole frame (``"left"`` or ``"right"``)."""
        return self.frame_id(self.feet[SIDES.index(side)])

    def standing_configuration(self) -> np.ndarray:
        """Upright configuration [q]: joints at zero (clipped into their limits), soles on z = 0.

        The pelvis is above the world origin and the lowest sole contact point on z = 0.
        """
        return self._on_floor(_upright(self.model))

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
                     if (b := _world_box(m, data, g)) is not None]  # fmt: skip
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
        box = _world_box(self.model, data, self.visual_model)
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
        if np.ndim(q_euler) != 2:
            return self.fusion.to_quaternion(q_euler, v_euler)
        out = [self.fusion.to_quaternion(qe, None if v_euler is None else v_euler[i])
               for i, qe in enumerate(q_euler)]  # fmt: skip
        q = np.array([o[0] for o in out]).reshape(-1, self.model.nq)
        return q, None if v_euler is None else np.array([o[1] for o in out])


def _upright(model: pin.Model) -> np.ndarray:
    """Neutral configuration with every 1-DoF joint at zero clipped into its limits."""
    q = pin.neutral(model)
    for jm in model.joints[2:]:
        if jm.nq == 1:
            lo, hi = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
            q[jm.idx_q] = np.clip(0.0, lo, hi) if lo <= hi else 0.0
    return q


def example_robot_names() -> tuple[str, ...]:
    """Names accepted by :func:`load_example` (example-robot-data's URDF robots)."""
    from example_robot_data.robots_loader import ROBOTS

    return tuple(sorted(k for k, cls in ROBOTS.items() if getattr(cls, "urdf_filename", "")))


def example_robot_path(name: str) -> tuple[Path, Path]:
    """URDF path and package directory of an example-robot-data robot."""
    from example_robot_data.robots_loader import ROBOTS, getModelPath

    cls = ROBOTS.get(name)
    if cls is None or not getattr(cls, "urdf_filename", ""):
        raise ModelError(
            f"unknown example-robot-data robot {name!r}; valid: {', '.join(example_robot_names())}"
        )
    sub = Path(cls.path) / cls.urdf_subpath / cls.urdf_filename
    root = Path(getModelPath(str(sub)))
    return root / sub, (root / "../..").resolve()


def example_robot_srdf(name: str) -> tuple[Path | None, str | None]:
    """An example-robot-data robot's SRDF path and the posture it starts from (its loader's
    ``ref_posture``), or (None, None) when it ships no SRDF."""
    from example_robot_data.robots_loader import ROBOTS

    cls = ROBOTS[name]
    if not getattr(cls, "srdf_filename", ""):
        return None, None
    urdf, _ = example_robot_path(name)
    path = urdf.parents[len(Path(cls.urdf_subpath).parts)] / cls.srdf_subpath / cls.srdf_filename
    return (path, getattr(cls, "ref_posture", None)) if path.is_file() else (None, None)


def load_example(
    name: str,
    ball_joints: str = "quaternion",
    feet=None,
    massless: str = "error",
    srdf=None,
    lock=(),
) -> Humanoid:
    """Load an example-robot-data robot by name (``"human"``, ``"talos"``...) as :func:`load`
    does (the robot's, even where a file of that name is in the working directory)."""
    path, package_dir = example_robot_path(name)  # raises, listing the valid names
    return _load(path, name, ball_joints, feet, [package_dir], massless, srdf, lock)


def load_recipe(recipe: dict) -> Humanoid:
    """Load a body again from its :attr:`Humanoid.recipe` (as a saved run stores it).

    Raises:
        ModelError: the recipe is not one :func:`load` wrote, or its body does not load.
    """
    if not isinstance(recipe, dict) or not ({"urdf", "example"} & recipe.keys()):
        raise ModelError("not a body recipe: needs 'urdf' (the URDF text) or 'example' (a name)")
    options = {k: recipe[k] for k in ("ball_joints", "massless", "srdf", "lock") if k in recipe}
    feet = recipe.get("feet")
    if feet is not None:
        options["feet"] = tuple(feet)
    if "example" in recipe:
        return load_example(str(recipe["example"]), **options)
    text = recipe["urdf"]
    if not isinstance(text, str):
        raise ModelError(f"a body recipe's 'urdf' must be URDF text, got {type(text).__name__}")
    path = recipe.get("path")
    # the original file, where it still holds the same text, resolves relative mesh paths
    if isinstance(path, str) and Path(path).is_file():
        try:
            same = Path(path).read_text(encoding="utf-8") == text
        except (OSError, UnicodeDecodeError):
            same = False
        if same:
            return load(path, **options)
    return load(text, **options)


def load(
    source,
    ball_joints: str = "quaternion",
    feet=None,
    package_dirs=(),
    massless: str = "error",
    srdf=None,
    lock=(),
) -> Humanoid:
    """Load a humanoid URDF with a free-flyer root.

    Args:
        source: A path to a URDF file, the URDF text itself, the name of a shipped body
            (:func:`humanoid.data.body_names`) or of an example-robot-data robot
            (:func:`example_robot_names`). A file of that name in the working directory wins.
        ball_joints: ``"quaternion"`` fuses hinge triplets into spherical joints;
            ``"euler"`` keeps the URDF's revolute joints.
        feet: Optional (left, right) frame names of the feet; found by name if omitted.
        package_dirs: Extra folders to resolve ``package://`` mesh URIs.
        massless: What to do with joints that move no mass (massless links at the end of a
            chain, such as romeo's fingers: nothing resists their acceleration and M(q) is
            singular). ``"error"`` raises a :class:`ModelError` naming them; ``"merge"`` locks
            them at their upright position, merging their links into their parents (exact:
            they carry no mass), as the hinge triplets' massless links are merged.
        srdf: An SRDF (path or text) whose group states become the body's
            :attr:`~Humanoid.postures`; an example-robot-data robot's own by default.
        lock: Names of hinges to lock at their upright value, their links merged into their
            parents (:func:`lock_foot_hinges`: a foot with toes made one piece).

    Returns:
        The :class:`Humanoid`.

    Raises:
        ModelError: the file is missing or malformed, a mass or inertia is invalid, a mesh
            cannot be found, a joint moves no mass (``massless="error"``), or no feet can be
            identified.
    """
    source, example, package_dirs = _named(source, package_dirs)
    return _load(source, example, ball_joints, feet, package_dirs, massless, srdf, lock)


def _load(source, example, ball_joints, feet, package_dirs, massless, srdf=None,
          lock=()) -> Humanoid:  # fmt: skip
    """:func:`load` of a path or URDF text; ``example``: the example-robot-data robot it is
    (its recipe names it), or None."""
    for name, registry, value in (("ball_joints", BALL_JOINTS, ball_joints),
                                  ("massless", MASSLESS, massless)):  # fmt: skip
        if (why := registry.refusal(value)) is not None:
            raise ModelError(f"{name}: {why}")
    text, path = _read(source)
    dirs = _package_dirs(path, package_dirs)
    label = str(path) if path else "<string>"
    recipe = {"example": example} if example else {"urdf": text}
    if path is not None and not example:
        recipe["path"] = str(path)
    recipe |= {"ball_joints": ball_joints, "massless": massless}
    if feet is not None:
        recipe["feet"] = list(feet)
    lock = [lock] if isinstance(lock, str) else list(lock)
    if lock:
        recipe["lock"] = lock
    reference = None
    if srdf is not None:
        srdf, _ = _read(srdf, "SRDF")
        recipe["srdf"] = srdf
    elif example:
        path_srdf, reference = example_robot_srdf(example)
        srdf = path_srdf.read_text(encoding="utf-8") if path_srdf else None
    declared = _validate(text, label, path, dirs)
    try:
        model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
        geoms = [_geometry(model, text, path, kind, dirs) for kind in ("VISUAL", "COLLISION")]
    except (RuntimeError, ValueError) as exc:
        raise ModelError(f"{label}: Pinocchio cannot build the model: {exc}") from None
    _check_built(model, declared, label)
    model, geoms = _massless_joints(model, geoms, massless, label)
    model, geoms = _locked_joints(model, geoms, lock, label)

    foot_frames = _find_feet(model, feet, label)
    _make_z_up(model, geoms, foot_frames)
    fusion = None
    euler_model = model
    if ball_joints == "quaternion":
        fusion, geoms = fuse_ball_joints(model, geoms)
        model = fusion.model
    soles, contacts = _add_sole_frames(model, geoms, foot_frames)
    postures = _srdf_postures(srdf, euler_model, fusion, label) if srdf else {}
    return Humanoid(
        model=model,
        data=model.createData(),
        visual_model=geoms[0],
        collision_model=geoms[1],
        feet=soles,
        contact_points=contacts,
        ball_joints=ball_joints,
        source=label,
        fusion=fusion,
        euler_model=euler_model,
        recipe=recipe,
        postures=postures,
        reference_posture=reference if reference in postures else None,
    )


def _srdf_postures(text: str, euler_model: pin.Model, fusion, label: str) -> dict:
    """The group states of an SRDF as configurations of the loaded model: each names joint
    values of the URDF (hinges, as the Euler model has them; the root and joints the model
    does not have, such as merged massless ones, are skipped), turned into the fused model's
    q."""
    try:
        root = etree.fromstring(text.encode("utf-8"))
    except etree.XMLSyntaxError as exc:
        raise ModelError(f"{label}: the SRDF is not well-formed XML: {exc}") from None
    postures = {}
    for state in root.iter("group_state"):
        q = _upright(euler_model)
        for joint in state.iter("joint"):
            name = joint.get("name", "")
            if not euler_model.existJointName(name):
                continue
            jm = euler_model.joints[euler_model.getJointId(name)]
            if jm.nq != 1 or jm.idx_q < 7:
                continue
            try:
                q[jm.idx_q] = float(joint.get("value", ""))
            except ValueError:
                raise ModelError(
                    f"{label}: SRDF posture {state.get('name')!r}: joint {name!r} has value "
                    f"{joint.get('value')!r}, not one number"
                ) from None
        postures[state.get("name", "")] = fusion.to_quaternion(q)[0] if fusion else q
    return postures


def _named(source, package_dirs):
    """A shipped body's or an example-robot-data robot's name, turned into its file:
    (source, robot name or None, package_dirs)."""
    if not isinstance(source, str) or "<" in source or Path(source).exists():
        return source, None, package_dirs
    from .data import body_path

    shipped = body_path(source)
    if shipped is not None:
        return shipped, None, package_dirs
    if source in example_robot_names():
        path, package_dir = example_robot_path(source)
        return path, source, [*package_dirs, package_dir]
    return source, None, package_dirs


def _massless_joints(model: pin.Model, geoms, mode: str, label: str):
    """Find the joints whose motion moves no inertia (their diagonal block of M at the upright
    configuration is zero); raise, or lock them (``pin.buildReducedModel``)."""
    if model.nv == 0:
        return model, geoms
    q = _upright(model)
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


def _locked_joints(model: pin.Model, geoms, names, label: str):
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
    reduced, geoms = _reduced(model, geoms, sorted(set(ids)), _upright(model))
    for name in parents:
        if reduced.existJointName(name):
            _merge_boxes(geoms[1], reduced.getJointId(name))
    return reduced, geoms


def lock_foot_hinges(h: Humanoid) -> Humanoid:
    """The body with its feet's own hinges (a foot with toes: its MTP) locked at their upright
    value, each foot one rigid piece (at MTP zero the rearfoot and the toes have the one-piece
    foot's mass, CoM and inertia); the body itself if its feet have none. For the controllers
    that plan a rigid foot (the fitted cycle's walk, motion tracking)."""
    from .constraints import foot_hinges

    model, names = h.model, []
    for side in SIDES:
        points = [h.frame_id(n) for n in h.contact_points[side]]
        names += [model.names[j] for j in foot_hinges(model, h.sole_id(side), points)]
    if not names:
        return h
    return load_recipe(h.recipe | {"lock": [*h.recipe.get("lock", []), *names]})


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


def child_link(model: pin.Model, joint: int) -> str:
    """The name of the link a joint moves (its first BODY frame)."""
    return next(
        (f.name for f in model.frames if f.parentJoint == joint and f.type == pin.FrameType.BODY),
        model.names[joint],
    )


def _read(source, kind: str = "URDF") -> tuple[str, Path | None]:
    if isinstance(source, Path) or (isinstance(source, str) and "<" not in source):
        path = Path(source)
        if not path.is_file():
            if kind != "URDF":
                raise ModelError(f"{kind} file not found: {path}")
            from .data import body_names

            raise ModelError(
                f"URDF file not found: {path} (a body may also be named: shipped bodies "
                f"{', '.join(body_names())}; example-robot-data robots "
                f"{', '.join(example_robot_names())})"
            )
        try:
            return path.read_text(encoding="utf-8"), path.resolve()
        except (OSError, UnicodeDecodeError) as exc:
            raise ModelError(f"cannot read {kind} file {path}: {exc}") from None
    if isinstance(source, str):
        return source, None
    raise ModelError(f"expected a {kind} path or {kind} text, got {type(source).__name__}")


def _package_dirs(path: Path | None, extra) -> list[str]:
    dirs = [str(Path(d)) for d in extra]
    if path is not None:
        dirs += [str(p) for p in list(path.parents)[:4]]
    try:
        from example_robot_data.robots_loader import getModelPath

        dirs.append(str((Path(getModelPath("human_description")) / "../..").resolve()))
    except (ImportError, OSError):  # pragma: no cover - example-robot-data is a dependency
        pass
    return dirs


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


def _validate(text: str, label: str, path: Path | None, dirs: list[str]) -> dict:
    """Check a URDF before Pinocchio sees it (its parser crashes on cycles, and urdfdom
    drops what it cannot read without a word). Returns each link's declared inertia
    (``pin.Inertia`` in the link frame), for :func:`_check_built`."""
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
    known, parent, names = set(links), {}, set()
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
        ends = []
        for end in ("parent", "child"):
            e = joint.find(end)
            link = e.get("link") if e is not None else None
            if link not in known:
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


def _check_built(model: pin.Model, declared: dict, label: str) -> None:
    """What Pinocchio built equals what the URDF declares: each joint's inertia is the sum of
    its links' declared inertias (a link that urdfdom dropped would be missing)."""
    frames = {}
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


def _geometry(model, text, path, kind, dirs):
    gtype = getattr(pin.GeometryType, kind)
    if path is not None:
        return pin.buildGeomFromUrdf(model, str(path), gtype, package_dirs=dirs)
    return pin.buildGeomFromUrdfString(model, text, gtype, package_dirs=dirs)


def _side_match(name: str, side: str) -> bool:
    n = name.lower()
    return side in n or re.search(rf"(^|[^a-z]){side[0]}([^a-z]|$)", n) is not None


def _find_feet(model: pin.Model, feet, label: str) -> tuple[str, str]:
    if feet is not None:
        feet = tuple(feet)
        if len(feet) != 2:
            raise ModelError(f"feet must be two frame names (left, right), got {feet!r}")
        for name in feet:
            if not model.existFrame(name):
                raise ModelError(f"{label}: no frame {name!r}; {_frame_hint(model)}")
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


def _frame_hint(model: pin.Model) -> str:
    names = [f.name for f in model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]
    return "frames: " + ", ".join(names)


def _make_z_up(model: pin.Model, geoms, feet: tuple[str, str]) -> None:
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


def _add_sole_frames(model: pin.Model, geoms, feet):
    """Sole frames and contact points: the model's own, or from the foot geometry's box."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, _upright(model))
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


def _world_box(model, data, geometry_model, joints=None):
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


def _foot_box(model, data, geoms, joint):
    """World bounding box of the foot's geometry: collision geometry first, visual otherwise
    (None if the foot has none)."""
    for gm in (geoms[1], geoms[0]):
        box = _world_box(model, data, gm, {joint})
        if box is not None:
            return box
    return None


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
