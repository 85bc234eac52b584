"""Load any humanoid URDF into Pinocchio with a free-flyer root: :func:`load` (see
:mod:`humanoid.model` for what loading does, in order)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pinocchio as pin
from lxml import etree

from ..errors import ModelError
from ..fusion import fuse_ball_joints
from ..variants import BALL_JOINTS, MASSLESS
from .checks import check_built, validate_urdf
from .feet import add_sole_frames, find_feet, make_z_up
from .humanoid import SIDES, Humanoid, upright
from .reduction import locked_joints, massless_joints

__all__ = [
    "example_robot_names",
    "example_robot_path",
    "example_robot_srdf",
    "load",
    "load_example",
    "load_recipe",
    "lock_foot_hinges",
]


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
    recipe: dict[str, Any] = {"example": example} if example else {"urdf": text}
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
    declared = validate_urdf(text, label, path, dirs)
    try:
        model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
        geoms = [_geometry(model, text, path, kind, dirs) for kind in ("VISUAL", "COLLISION")]
    except (RuntimeError, ValueError) as exc:
        raise ModelError(f"{label}: Pinocchio cannot build the model: {exc}") from None
    check_built(model, declared, label)
    model, geoms = massless_joints(model, geoms, massless, label)
    model, geoms = locked_joints(model, geoms, lock, label)

    foot_frames = find_feet(model, feet, label)
    make_z_up(model, geoms, foot_frames)
    fusion = None
    euler_model = model
    if ball_joints == "quaternion":
        fusion, geoms = fuse_ball_joints(model, geoms)
        model = fusion.model
    soles, contacts = add_sole_frames(model, geoms, foot_frames)
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
        q = upright(euler_model)
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
    from ..data import body_path

    shipped = body_path(source)
    if shipped is not None:
        return shipped, None, package_dirs
    if source in example_robot_names():
        path, package_dir = example_robot_path(source)
        return path, source, [*package_dirs, package_dir]
    return source, None, package_dirs


def lock_foot_hinges(h: Humanoid) -> Humanoid:
    """The body with its feet's own hinges (a foot with toes: its MTP) locked at their upright
    value, each foot one rigid piece (at MTP zero the rearfoot and the toes have the one-piece
    foot's mass, CoM and inertia); the body itself if its feet have none. For the controllers
    that plan a rigid foot (the fitted cycle's walk, motion tracking)."""
    from ..constraints import foot_hinges

    model, names = h.model, []
    for side in SIDES:
        points = [h.frame_id(n) for n in h.contact_points[side]]
        names += [model.names[j] for j in foot_hinges(model, h.sole_id(side), points)]
    if not names:
        return h
    return load_recipe(h.recipe | {"lock": [*h.recipe.get("lock", []), *names]})


def _read(source, kind: str = "URDF") -> tuple[str, Path | None]:
    if isinstance(source, Path) or (isinstance(source, str) and "<" not in source):
        path = Path(source)
        if not path.is_file():
            if kind != "URDF":
                raise ModelError(f"{kind} file not found: {path}")
            from ..data import body_names

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


def _geometry(model, text, path, kind, dirs):
    gtype = getattr(pin.GeometryType, kind)
    if path is not None:
        return pin.buildGeomFromUrdf(model, str(path), gtype, package_dirs=dirs)
    return pin.buildGeomFromUrdfString(model, text, gtype, package_dirs=dirs)
