"""Scenes: a TOML file <-> a frozen, validated :class:`Scene`.

A scene names the body, the initial state, the time step and integrator, the effects it wants
and the stabilisation of its constraints. Everything it does not name is not simulated.
Example (the shipped ``standing`` scene, :mod:`humanoid.data`)::

    name = "standing"
    duration = 2.0            # [s]
    dt = 0.001                # [s] step (the control and contact tick for "adaptive")
    integrator = "rk4"        # euler | semi_implicit_euler | rk4 | adaptive (humanoid variants)
    record_rate = 100.0       # [Hz]

    [body]
    urdf = "adult_male"   # a shipped body or robot by name, or a path relative to this file
                          # (or height/mass/sex instead of urdf)
    ball_joints = "quaternion"

    [initial]
    configuration = "standing"    # or a list of nq numbers
    base_velocity = [0, 0, 0, 0, 0, 0]   # [m/s, rad/s] in the pelvis frame

    [effects]
    gravity = [0, 0, -9.81]
    [[effects.contacts]]
    foot = "left"
    kind = "weld"                  # weld | points
    mu = 0.8
    unilateral = false

    [controller]
    kind = "posture"
    frequency = 4.0           # [Hz] closed-loop bandwidth of every joint
    damping_ratio = 1.0

    [stabilisation]
    baumgarte = 20.0    # time constant in steps (tau = 20 dt); 0 switches it off
    projection = false

Unknown keys, wrong types and impossible values raise :class:`SceneError` naming the file, the
key and the reason. A scene is data: it validates its own fields and loads nothing. What needs
its body (the frames it pushes, the size of its initial configuration) is checked once, when a
simulation sets it up on the body it builds (:func:`humanoid.simulation.check_scene`).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import MISSING, asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import NoReturn

from .anthropometry import BodyParameters
from .errors import BodyParameterError, SceneError
from .variants import (
    BACKENDS,
    BALL_JOINTS,
    CONTACT_KINDS,
    CONTACT_SOLVERS,
    CONTROLLERS,
    FORMULATIONS,
    INTEGRATORS,
    JOINT_LIMITS,
    MASSLESS,
)

__all__ = [
    "Contact",
    "Controller",
    "Effects",
    "GroundSpec",
    "Initial",
    "JointLimitSpec",
    "PushSpec",
    "Scene",
    "Stabilisation",
]


@dataclass(frozen=True)
class Contact:
    """A foot on the ground: ``weld`` (6D at the sole frame) or ``points`` (4 x 3D corners)."""

    foot: str
    kind: str = "weld"
    mu: float = 0.8
    unilateral: bool = False
    start: float = 0.0
    end: float = math.inf


@dataclass(frozen=True)
class PushSpec:
    """An external push from ``start`` for ``duration`` [s]: a force [N] at a frame's origin
    and a torque [N m], both in world axes. It acts on the whole body, free flyer included."""

    frame: str
    force: tuple[float, float, float]
    start: float
    duration: float
    torque: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class JointLimitSpec:
    """Joint ranges: ``spring`` (a stiff spring-damper beyond each limit, any integrator) or
    ``constraint`` (unilateral constraints in the ground contact's solve: ranges that hold)."""

    kind: str = "spring"  # spring | constraint
    stiffness: float = 2000.0  # [N m/rad]
    damping: float = 20.0  # [N m s/rad]


@dataclass(frozen=True)
class GroundSpec:
    """Rigid ground contact with Coulomb friction on the floor z = 0 for the bodies listed:
    ``all`` (every collision geometry), ``feet``, or link names."""

    bodies: str | tuple[str, ...] = "all"
    mu: float = 0.8
    # [m] contact candidates closer than this to the floor (or than 5 m/s times the step,
    # humanoid.constraints.ground.SPECULATIVE_SPEED, if that is wider)
    margin: float = 0.01
    tolerance: float = 1e-9  # the contact solver's tolerance
    solver: str = "kernel"  # the conic solver (humanoid.variants.CONTACT_SOLVERS)


@dataclass(frozen=True)
class Effects:
    """The effects a scene simulates; what is absent costs nothing."""

    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    coriolis: bool = True
    damping: float = 0.0  # [N m s/rad]
    springs: float = 0.0  # [N m/rad], towards the initial configuration
    joint_limits: JointLimitSpec | None = None
    ground: GroundSpec | None = None
    contacts: tuple[Contact, ...] = ()
    pushes: tuple[PushSpec, ...] = ()


@dataclass(frozen=True)
class Controller:
    """``posture``: PD hold of the initial posture, by bandwidth (``frequency`` [Hz] and
    ``damping_ratio``, gains scaled by each joint's inertia) or by absolute ``kp`` [N m/rad]
    and ``kd`` [N m s/rad] when ``frequency`` is 0."""

    kind: str = "none"  # none | posture
    frequency: float = 0.0  # [Hz]
    damping_ratio: float = 1.0
    kp: float = 0.0  # [N m/rad]
    kd: float = 0.0  # [N m s/rad]


@dataclass(frozen=True)
class Stabilisation:
    baumgarte: float = 0.0  # Baumgarte time constant in steps; 0 = off
    projection: bool = False  # project q and v on the constraint manifold after each step
    quaternions: str = "lie"  # lie | coordinates (the seeds' norm-constrained formulation)
    backend: str = "native"  # native (solved in Pinocchio's C++) | reference (NumPy KKT)


@dataclass(frozen=True)
class Initial:
    configuration: str | tuple[float, ...] = "standing"
    lift: float = 0.0  # [m] the initial configuration raised by this (a drop)
    base_velocity: tuple[float, ...] = (0.0,) * 6
    joint_velocity: float | tuple[float, ...] = 0.0


@dataclass(frozen=True)
class Scene:
    """A simulation scene (see the module docstring for its TOML form)."""

    name: str = "scene"
    body: str | BodyParameters = "adult_male"  # a URDF path or a body's name (see load)
    ball_joints: str = "quaternion"
    massless: str = "error"  # error | merge: joints that move no mass (see humanoid.load)
    duration: float = 1.0  # [s]
    dt: float = 1e-3  # [s]
    integrator: str = "rk4"
    rtol: float = 1e-6
    atol: float = 1e-8
    record_rate: float = 100.0  # [Hz]
    initial: Initial = field(default_factory=Initial)
    effects: Effects = field(default_factory=Effects)
    controller: Controller = field(default_factory=Controller)
    stabilisation: Stabilisation = field(default_factory=Stabilisation)
    source: str = "<scene>"

    def __post_init__(self) -> None:
        _validate(self)

    # -- files ---------------------------------------------------------------------------
    @classmethod
    def load(cls, path: str | Path) -> Scene:
        """Read and validate a scene TOML file (or a shipped scene by name: ``"push"``)."""
        from .data import scene_names, scene_path

        if not Path(path).is_file() and (shipped := scene_path(str(path))) is not None:
            path = shipped
        path = Path(path)
        if not path.is_file():
            raise SceneError(
                f"scene file not found: {path} (shipped scenes: {', '.join(scene_names())})"
            )
        try:
            doc = tomllib.loads(path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError, RecursionError) as exc:
            raise SceneError(f"{path}: not valid TOML: {type(exc).__name__}: {exc}") from None
        except OSError as exc:
            raise SceneError(f"cannot read scene file {path}: {exc}") from None
        return cls.from_dict(doc, source=str(path), base=path.parent)

    @classmethod
    def from_dict(cls, doc: dict, source: str = "<scene>", base: Path | None = None) -> Scene:
        """Build a scene from the TOML structure (relative URDF paths resolve from ``base``)."""
        r = _Reader(source)
        tables = ("body", "initial", "effects", "controller", "stabilisation")
        scalars = {f.name for f in fields(cls)} - {"source", "ball_joints", "massless", *tables}
        top = r.section(doc, "", scalars | set(tables))
        kw = {k: v for k, v in top.items() if k not in tables}
        body_keys = {"urdf", "height", "mass", "sex", "ball_joints", "massless", "segment_lengths",
                     "toes"}  # fmt: skip
        body = r.section(top.get("body", {}), "body", body_keys)
        if "urdf" in body:
            if {"height", "mass", "sex", "toes"} & body.keys():
                raise SceneError(f"{source}: [body] give either urdf or height/mass/sex/toes, "
                                 "not both")  # fmt: skip
            urdf = r.typed(body["urdf"], str, "body.urdf")
            p = Path(urdf)
            if base is not None and not p.is_absolute() and (base / p).exists():
                p = base / p
            kw["body"] = str(p)
        elif body:
            try:
                kw["body"] = BodyParameters(
                    body.get("height", 0.0),
                    body.get("mass", 0.0),
                    body.get("sex", "male"),
                    body.get("segment_lengths", {}),
                    body.get("toes", True),
                )
            except BodyParameterError as exc:
                raise SceneError(f"{source}: [body] {exc}") from None
        for key in ("ball_joints", "massless"):
            if key in body:
                kw[key] = r.typed(body[key], str, f"body.{key}")
        kw["initial"] = r.dataclass(Initial, top.get("initial", {}), "initial")
        kw["controller"] = r.dataclass(Controller, top.get("controller", {}), "controller")
        kw["stabilisation"] = r.dataclass(
            Stabilisation, top.get("stabilisation", {}), "stabilisation"
        )
        eff = dict(r.section(top.get("effects", {}), "effects", {f.name for f in fields(Effects)}))
        eff["contacts"] = tuple(
            r.dataclass(Contact, c, f"effects.contacts[{i}]")
            for i, c in enumerate(r.typed(eff.get("contacts", []), list, "effects.contacts"))
        )
        eff["pushes"] = tuple(
            r.dataclass(PushSpec, c, f"effects.pushes[{i}]")
            for i, c in enumerate(r.typed(eff.get("pushes", []), list, "effects.pushes"))
        )
        if "joint_limits" in eff:
            eff["joint_limits"] = r.dataclass(
                JointLimitSpec, eff["joint_limits"], "effects.joint_limits"
            )
        if "ground" in eff:
            ground = dict(r.section(eff["ground"], "effects.ground",
                                    {f.name for f in fields(GroundSpec)}))  # fmt: skip
            if "bodies" in ground and isinstance(ground["bodies"], list):
                ground["bodies"] = tuple(
                    r.typed(b, str, f"effects.ground.bodies[{i}]")
                    for i, b in enumerate(ground["bodies"])
                )
            eff["ground"] = r.dataclass(GroundSpec, ground, "effects.ground", nested=True)
        kw["effects"] = r.dataclass(Effects, eff, "effects", nested=True)
        for key in ("duration", "dt", "rtol", "atol", "record_rate"):
            if key in kw:
                kw[key] = r.number(kw[key], key)
        for key in ("name", "integrator"):
            if key in kw:
                kw[key] = r.typed(kw[key], str, key)
        try:
            return cls(**kw, source=source)
        except SceneError as exc:
            raise SceneError(f"{source}: {exc}") from None

    def to_dict(self) -> dict:
        """The TOML structure of this scene (inverse of :meth:`from_dict`)."""
        skip = ("source", "body", "ball_joints", "massless")
        d = {
            f.name: asdict(v) if hasattr(v, "__dataclass_fields__") else v
            for f in fields(self)
            if f.name not in skip and (v := getattr(self, f.name)) is not None
        }
        if isinstance(self.body, BodyParameters):
            body = {"height": self.body.height, "mass": self.body.mass, "sex": self.body.sex}
            if self.body.segment_lengths:
                body["segment_lengths"] = dict(self.body.segment_lengths)
            if not self.body.toes:
                body["toes"] = False
        else:
            body = {"urdf": self.body}
        body["ball_joints"] = self.ball_joints
        if self.massless != "error":
            body["massless"] = self.massless
        d["body"] = body
        for key in ("joint_limits", "ground"):
            if d["effects"][key] is None:
                del d["effects"][key]
        return _drop_inf(d)

    def dumps(self) -> str:
        """TOML text of this scene."""
        return _toml(self.to_dict())

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(self.dumps(), encoding="utf-8")
        return path

    def replace(self, **changes) -> Scene:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def energy_exchanges(self) -> list[str]:
        """What takes energy from the body or gives it some in this scene (empty: the energy is
        conserved, and its change is the integrator's drift)."""
        e, why = self.effects, []
        if e.damping > 0:
            why.append("damping")
        if e.pushes:
            why.append("pushes")
        if self.controller.kind != "none":
            why.append("controller")
        if e.ground is not None:
            why.append("ground impacts and friction")
        if e.joint_limits is not None and e.joint_limits.kind == "constraint":
            why.append("joint-range impacts")
        elif e.joint_limits is not None and e.joint_limits.damping > 0:
            why.append("joint-range damping")
        return why


class _Reader:
    """Checks keys and types of the TOML structure, with the file and key in every message."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str, reason: str) -> NoReturn:
        raise SceneError(f"{self.source}: {key}: {reason}")

    def section(self, d, name: str, valid: set[str]) -> dict:
        if not isinstance(d, dict):
            self.fail(name or "<top>", f"expected a table, got {type(d).__name__}")
        for k in d:
            if k not in valid:
                where = f"[{name}] " if name else ""
                raise SceneError(
                    f"{self.source}: {where}unknown key {k!r}; valid: {', '.join(sorted(valid))}"
                )
        return d

    def typed(self, value, kind, key):
        if kind is float:
            return self.number(value, key)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            self.fail(key, f"expected {kind.__name__}, got {type(value).__name__} {value!r}")
        return value

    def number(self, value, key) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.fail(key, f"expected a number, got {type(value).__name__} {value!r}")
        try:
            return float(value)
        except OverflowError:
            self.fail(key, f"the number {value} is too large")

    def numbers(self, value, key) -> tuple[float, ...]:
        value = self.typed(value, list, key)
        return tuple(self.number(x, f"{key}[{i}]") for i, x in enumerate(value))

    def dataclass(self, cls, d, name: str, nested: bool = False):
        """Fields of ``cls`` from a table, each checked against its annotation."""
        d = self.section(d, name, {f.name for f in fields(cls)})
        missing = [f.name for f in fields(cls) if f.name not in d
                   and f.default is MISSING and f.default_factory is MISSING]  # fmt: skip
        if missing:
            self.fail(name, f"missing key(s) {', '.join(missing)}")
        out = {}
        for f in fields(cls):
            if f.name not in d:
                continue
            value, key, t = d[f.name], f"{name}.{f.name}", f.type
            if nested and f.name in ("contacts", "pushes", "joint_limits", "ground", "bodies"):
                out[f.name] = value
            elif t == "bool":
                out[f.name] = self.typed(value, bool, key)
            elif t == "float":
                out[f.name] = self.number(value, key)
            elif t == "str":
                out[f.name] = self.typed(value, str, key)
            elif t.startswith("tuple"):
                out[f.name] = self.numbers(value, key)
            elif t.startswith("str |"):
                out[f.name] = value if isinstance(value, str) else self.numbers(value, key)
            elif t.startswith("float |"):
                is_number = isinstance(value, int | float) and not isinstance(value, bool)
                out[f.name] = self.number(value, key) if is_number else self.numbers(value, key)
            else:  # pragma: no cover - every field type is listed above
                raise SceneError(f"no reader for {t}")
        try:
            return cls(**out)
        except TypeError as exc:
            raise SceneError(f"{self.source}: [{name}] {exc}") from None


def _finite(obj, key: str) -> None:
    """Every number of a scene is finite (NaN never means "off"); only a contact's end may be
    infinite (for ever)."""
    if isinstance(obj, float):
        if math.isnan(obj) or (math.isinf(obj) and not key.endswith(".end")):
            raise SceneError(f"{key}: must be a finite number, got {obj!r}")
    elif isinstance(obj, tuple | list):
        for i, x in enumerate(obj):
            _finite(x, f"{key}[{i}]")
    elif hasattr(obj, "__dataclass_fields__"):
        for f in fields(obj):
            _finite(getattr(obj, f.name), f"{key}.{f.name}" if key else f.name)


def _bad(key, reason) -> NoReturn:
    """Refuse a scene: ``key``'s setting and why."""
    raise SceneError(f"{key}: {reason}")


def _validate_effects(s: Scene) -> None:
    """The scene's effects in range: gravity, damping, springs, joint limits and the ground."""
    e = s.effects
    if len(e.gravity) != 3 or not all(math.isfinite(x) for x in e.gravity):
        _bad("effects.gravity", f"must be 3 finite numbers, got {e.gravity!r}")
    if e.damping < 0 or e.springs < 0:
        _bad("effects", "damping and springs must be >= 0")
    lim = e.joint_limits
    if lim is not None:
        if not (
            min(lim.stiffness, lim.damping) >= 0 and math.isfinite(lim.stiffness + lim.damping)
        ):
            _bad("effects.joint_limits", "stiffness and damping must be finite and >= 0")
        if (why := JOINT_LIMITS.refusal(lim.kind)) is not None:
            _bad(JOINT_LIMITS.key, why)
        if lim.kind == "constraint" and e.ground is None:
            _bad("effects.joint_limits.kind", "constraint ranges are solved with the ground "
                "contact: add [effects.ground] (bodies = [] for none)")  # fmt: skip
    if e.ground is not None:
        g = e.ground
        if not (math.isfinite(g.mu) and g.mu >= 0):
            _bad("effects.ground.mu", f"friction coefficient must be >= 0, got {g.mu!r}")
        if not (math.isfinite(g.margin) and 0 < g.margin <= 0.1):
            _bad("effects.ground.margin", f"must be in (0, 0.1] m, got {g.margin!r}")
        if not (math.isfinite(g.tolerance) and 0 < g.tolerance < 1):
            _bad("effects.ground.tolerance", f"must be in (0, 1), got {g.tolerance!r}")
        if (why := CONTACT_SOLVERS.refusal(g.solver)) is not None:
            _bad(CONTACT_SOLVERS.key, why)
        if not isinstance(g.bodies, str | tuple):
            _bad("effects.ground.bodies", f"must be all, feet or a list of links, got {g.bodies!r}")
        if isinstance(g.bodies, str) and g.bodies not in ("all", "feet"):
            _bad("effects.ground.bodies", f"must be all, feet or a list of links, got {g.bodies!r}")
        if s.integrator != "semi_implicit_euler":
            _bad("integrator", "ground contact is solved at the velocity level once per step: "
                f"use semi_implicit_euler, not {s.integrator!r}")  # fmt: skip
        if e.contacts:
            _bad("effects.contacts", "welded or pinned feet and [effects.ground] in one scene are "
                "not supported yet: the ground holds the feet by friction")  # fmt: skip
        if s.stabilisation.quaternions != "lie" or s.stabilisation.projection:
            _bad(
                "stabilisation", "ground contact needs the Lie-group quaternions and no projection"
            )


def _validate_events(e: Effects) -> None:
    """The scene's contacts (feet welded or pinned for a while) and pushes in range."""
    feet = set()
    for i, c in enumerate(e.contacts):
        key = f"effects.contacts[{i}]"
        if c.foot not in ("left", "right"):
            _bad(f"{key}.foot", f"must be 'left' or 'right', got {c.foot!r}")
        if c.foot in feet:
            _bad(f"{key}.foot", f"{c.foot} foot appears twice")
        feet.add(c.foot)
        if (why := CONTACT_KINDS.refusal(c.kind)) is not None:
            _bad(f"{key}.kind", why)
        if not (math.isfinite(c.mu) and c.mu >= 0):
            _bad(f"{key}.mu", f"friction coefficient must be >= 0, got {c.mu!r}")
        if not c.end > c.start >= 0:
            _bad(f"{key}", f"needs 0 <= start < end, got start {c.start}, end {c.end}")
    for i, p in enumerate(e.pushes):
        key = f"effects.pushes[{i}]"
        for name, unit in (("force", "N"), ("torque", "N m")):
            value = getattr(p, name)
            if len(value) != 3 or not all(math.isfinite(x) for x in value):
                _bad(f"{key}.{name}", f"must be 3 finite numbers [{unit}], got {value!r}")
        if not (math.isfinite(p.start) and math.isfinite(p.duration)):
            _bad(key, f"start and duration must be finite, got {p.start}, {p.duration}")
        if p.duration <= 0 or p.start < 0:
            _bad(key, "needs start >= 0 and duration > 0")


def _validate(s: Scene) -> None:
    """Every setting of a scene in range (:class:`SceneError` naming the first that is not)."""
    _finite(s, "")

    for key in ("duration", "dt", "record_rate"):
        value = getattr(s, key)
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            _bad(key, f"must be a finite number > 0, got {value!r}")
    if s.dt > s.duration:
        _bad("dt", f"the step {s.dt} s is longer than the duration {s.duration} s")
    if s.stabilisation.backend == "pinocchio":
        _bad("stabilisation.backend", "'pinocchio' is now 'native' (the default): the project's "
            "constraints solved in Pinocchio's C++")  # fmt: skip
    for registry, value in ((INTEGRATORS, s.integrator), (BALL_JOINTS, s.ball_joints),
                            (MASSLESS, s.massless), (CONTROLLERS, s.controller.kind),
                            (FORMULATIONS, s.stabilisation.quaternions),
                            (BACKENDS, s.stabilisation.backend)):  # fmt: skip
        if (why := registry.refusal(value)) is not None:
            _bad(registry.key, why)
    if not (s.rtol > 0 and s.atol > 0):
        _bad("rtol/atol", "tolerances must be > 0")
    _validate_effects(s)
    _validate_events(s.effects)
    ctl = s.controller
    if min(ctl.kp, ctl.kd, ctl.frequency, ctl.damping_ratio) < 0:
        _bad("controller", "gains, frequency and damping ratio must be >= 0")
    if ctl.kind == "posture" and ctl.frequency == 0 and ctl.kp == 0:
        _bad("controller", "a posture controller needs frequency > 0 or kp > 0")
    st = s.stabilisation
    if st.baumgarte < 0 or (0 < st.baumgarte < 1):
        _bad(
            "stabilisation.baumgarte",
            f"time constant must be 0 (off) or >= 1 step, got {st.baumgarte}",
        )
    ini = s.initial
    if isinstance(ini.configuration, str) and ini.configuration != "standing":
        _bad("initial.configuration", f"must be 'standing' or a list, got {ini.configuration!r}")
    if not (math.isfinite(ini.lift) and 0.0 <= ini.lift <= 100.0):
        _bad("initial.lift", f"must be a height in [0, 100] m, got {ini.lift!r}")
    if len(ini.base_velocity) != 6:
        _bad("initial.base_velocity", f"needs 6 numbers, got {len(ini.base_velocity)}")


def _drop_inf(d):
    if isinstance(d, dict):
        return {
            k: _drop_inf(v) for k, v in d.items() if not (isinstance(v, float) and math.isinf(v))
        }
    if isinstance(d, list | tuple):
        return [_drop_inf(x) for x in d]
    return d


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return "[" + ", ".join(_value(x) for x in v) + "]"


def _toml(d: dict, prefix: str = "") -> str:
    """A minimal TOML writer for the scene structure (scalars, lists, tables, table arrays)."""
    lines, tables, arrays = [], [], []
    for k, v in d.items():
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            arrays.append((k, v))
        elif isinstance(v, list) and not v:
            continue
        else:
            lines.append(f"{k} = {_value(v)}")
    out = "\n".join(lines) + ("\n" if lines else "")
    for k, v in tables:
        name = f"{prefix}{k}"
        out += f"\n[{name}]\n" + _toml(v, name + ".")
    for k, items in arrays:
        for item in items:
            out += f"\n[[{prefix}{k}]]\n" + _toml(item, f"{prefix}{k}.")
    return out
