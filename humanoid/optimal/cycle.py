"""An optimised gait cycle as data: what a collocation solved (:class:`Solution`), a half
stride of a gait (:class:`GaitSolution`), its start from standing and stop to standing
(:class:`Transition`), its stride along a circle (:class:`TurnSolution`), and their storage
(:func:`save_gait`, :func:`load_gait`, the package's cycles and the user's cache:
:func:`stored_gait`, :func:`stored_transition`, :func:`stored_turn`).

Needs numpy and Pinocchio only, not casadi: a walk reads a shipped or cached cycle without the
optimal-control extra (:mod:`humanoid.optimal.gait` optimises one, with casadi).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cache import cache_dir as user_cache
from ..cache import model_key
from ..errors import HumanoidError, OptimalControlError
from .coordinates import OcpModel, build_ocp_model

__all__ = [
    "KINDS", "MIN_RADIUS", "REVISION", "SHIPPED_SPEEDS", "TURN_REVISION", "GaitSolution",
    "Phase", "Solution", "Transition", "TurnSolution", "body_key", "cache_dir", "check_radius",
    "contact_points", "default_speed", "gait_file", "gait_phases", "interval_sets", "load_gait",
    "load_transition", "load_turn", "save_gait", "save_transition", "save_turn", "stored",
    "stored_gait", "stored_transition", "stored_turn", "transition_file", "transition_phases",
    "turn_file", "turn_phases",
]  # fmt: skip

NODES = (5, 12, 8)  # collocation intervals in the three phases
OBJECTIVES = ("tracking", "predictive")
KINDS = ("start", "stop")  # transitions from standing into a cycle, and out of it to standing
# a transition's intervals per phase; its standing phase's duration (guess, bounds) [s]: its
# other phases last about as long as the cycle's phases they repeat
START_NODES, STOP_NODES = (8, 8, 3, 4, 8, 4), (4, 8, 4, 8, 8)
STANDING = (0.6, (0.3, 1.5))
MIN_RADIUS = 1.0  # [m] the tightest circle a turn is optimised along
# [m/s] the speeds the default bodies' (with toes) tracking cycles also ship at, beside their
# free speed: warm-started chains down and up from it (``make gaits``)
SHIPPED_SPEEDS = (0.8, 1.0, 1.2, 1.6, 1.8)


@dataclass(frozen=True)
class Phase:
    """A stretch of the motion with one set of points in contact.

    Attributes:
        duration: [s] the phase's duration (the initial guess when ``free`` is set).
        contacts: The contact frames that stick to the floor during the phase.
        intervals: Collocation intervals in the phase.
        free: Bounds (low, high) [s] if the duration is optimised, else None.
    """

    duration: float
    contacts: tuple[str, ...]
    intervals: int = 10
    free: tuple[float, float] | None = None


@dataclass
class Solution:
    """A solved (or failed) collocation.

    Attributes:
        t: [s] node times (N + 1). x, v, a, tau: per node (N + 1, n); tau's first six (the
        root's) are the dynamics' residual. forces: contact frame -> (N + 1, 3) [N] world-axes
        force, zero where the point is not in contact. durations: the phases' [s].
        success: IPOPT converged. status: its return status. iterations, seconds: the solve's
        cost. defect: the largest collocation defect at the solution. dynamics: the largest
        root residual [N, N m]. objective: its value. terms: the objective's terms' values.
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray
    forces: dict
    durations: np.ndarray
    success: bool
    status: str
    iterations: int
    seconds: float
    defect: float
    dynamics: float
    objective: float
    terms: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        return (f"Solution({self.status}, {len(self.t)} nodes over {self.t[-1]:.3f} s, "
                f"{self.iterations} iterations, defect {self.defect:.1e})")  # fmt: skip


def contact_points(om: OcpModel, side: str) -> dict:
    """A side's contact points: heel, meta (metatarsal heads; None without toes), toe."""
    model = om.model

    def pair(kind):
        names = (f"{side}_{kind}_inner", f"{side}_{kind}_outer")
        return names if all(model.existFrame(n) for n in names) else None

    heel, meta, toe = pair("heel"), pair("meta"), pair("toe")
    if heel is None or toe is None:
        raise OptimalControlError(
            f"the gait needs {side}_heel_inner|outer and {side}_toe_inner|outer contact frames"
        )
    return {"heel": heel, "meta": meta, "toe": toe}


def gait_phases(om: OcpModel, durations, nodes=NODES, free=None) -> list[Phase]:
    """The half stride's three phases (see the module)."""
    r, l = contact_points(om, "right"), contact_points(om, "left")
    r_toes = (r["meta"] or ()) + r["toe"]
    l_toes = (l["meta"] or ()) + l["toe"]
    contacts = (r["heel"] + l_toes, r["heel"] + (r["meta"] or ()) + r["toe"], r_toes)
    free = free or [None] * 3
    return [Phase(float(d), c, n, f) for d, c, n, f in zip(durations, contacts, nodes, free,
                                                           strict=True)]  # fmt: skip


@dataclass
class GaitSolution:
    """An optimised half stride and what it was asked.

    Attributes:
        solution: The collocation's :class:`~humanoid.optimal.problem.Solution` (the OCP
            model's coordinates).
        om: The :class:`OcpModel`.
        speed: [m/s] the mean speed. objective: ``"tracking"`` or ``"predictive"``.
        points: per side, its contact points by kind (heel, meta, toe).
        nodes: collocation intervals per phase.
    """

    solution: Solution
    om: OcpModel
    speed: float
    objective: str
    points: dict
    nodes: tuple = NODES

    def __repr__(self) -> str:
        s = self.solution
        return (f"GaitSolution({self.objective}, {self.speed:.2f} m/s, {self.cadence:.1f} "
                f"steps/min, step {self.step_length:.3f} m, {s.status}, {s.iterations} "
                f"iterations)")  # fmt: skip

    @property
    def period(self) -> float:
        """[s] the whole stride's duration (two half strides)."""
        return 2.0 * float(self.solution.t[-1])

    @property
    def step_length(self) -> float:
        return float(self.solution.x[-1, 0] - self.solution.x[0, 0])

    @property
    def cadence(self) -> float:
        """[steps/min]."""
        return 120.0 / self.period

    def stride(self):
        """The whole stride: (t, x, v, forces) over both halves (the second mirrored), x in
        the OCP model's coordinates, forces per contact frame [N]."""
        s, om = self.solution, self.om
        T = s.t[-1]
        x2 = om.reflect(s.x[1:])
        x2[:, 0] += self.step_length
        t = np.concatenate([s.t, T + s.t[1:]])
        x = np.vstack([s.x, x2])
        v = np.vstack([s.v, om.reflect(s.v[1:])])
        n = len(s.t)
        zero = np.zeros((n, 3))
        names = set(s.forces) | {_mirror_name(p) for p in s.forces}
        forces = {}
        for p in sorted(names):
            mirrored = s.forces.get(_mirror_name(p), zero)[1:] * np.array([1.0, -1.0, 1.0])
            forces[p] = np.vstack([s.forces.get(p, zero), mirrored])
        return t, x, v, forces

    def contact_sets(self) -> list:
        """The contact points down in each collocation interval of the whole stride (the
        second half's mirrored)."""
        half = interval_sets(gait_phases(self.om, self.solution.durations, self.nodes))
        return half + [{_mirror_name(p) for p in c} for c in half]

    def foot_forces(self):
        """(t, {side: (N, 3) summed force [N]}) over the stride."""
        t, _, _, forces = self.stride()
        out = {}
        for side in ("left", "right"):
            out[side] = sum(f for p, f in forces.items() if p.startswith(side))
        return t, out


@dataclass
class Transition:
    """A solved start or stop.

    Attributes:
        kind: ``"start"`` or ``"stop"``. solution: the collocation's
            :class:`~humanoid.optimal.problem.Solution` (the OCP model's coordinates; a start's
            last node is at the cycle's left heel strike, a stop's first node at a right one).
        gait: the cycle it joins. phases: its phases.
    """

    kind: str
    solution: Solution
    gait: GaitSolution
    phases: tuple

    @property
    def join(self) -> float:
        """[m] the pelvis's x where the transition meets the cycle: a start's end (at the
        cycle's left heel strike), a stop's beginning (at a right one)."""
        s = self.solution
        return float(s.x[-1, 0] if self.kind == "start" else s.x[0, 0])

    def contact_sets(self) -> list:
        """The contact points down in each collocation interval."""
        return interval_sets(self.phases)


def transition_phases(gait: GaitSolution, kind: str) -> list[Phase]:
    """A start's or a stop's phases (:mod:`humanoid.optimal.transitions` says which)."""
    if kind not in KINDS:
        raise OptimalControlError(f"a transition is one of {KINDS}, got {kind!r}")
    om = gait.om
    d1, d2, d3 = (float(d) for d in gait.solution.durations)
    r, l = contact_points(om, "right"), contact_points(om, "left")
    right = r["heel"] + (r["meta"] or ()) + r["toe"]
    left = l["heel"] + (l["meta"] or ()) + l["toe"]
    left_toes = (l["meta"] or ()) + l["toe"]
    guess, bounds = STANDING
    r_toes = (r["meta"] or ()) + r["toe"]

    def free(d, lo=0.5, hi=2.0):
        return d, (lo * d, hi * d)

    contacts: tuple  # per phase: the points in contact
    spec: tuple  # per phase: (duration guess, its bounds)
    nodes: tuple[int, ...]
    if kind == "start":  # two steps: the right, then the left to the cycle's left heel strike
        contacts = (right + left, left, left_toes, r["heel"] + left_toes, right, r_toes)
        spec = ((guess, bounds), free(d2), free(d3), free(d1), free(d2), free(d3))
        nodes = START_NODES
    else:
        # two steps: the left a short one, the right beside it; then both flat to rest
        contacts = (r["heel"] + left_toes, right, l["heel"] + r_toes, left, right + left)
        spec = (free(d1), free(d2), free(d1), free(d2), (guess, bounds))
        nodes = STOP_NODES
    return [Phase(d, c, n, b) for c, (d, b), n in zip(contacts, spec, nodes, strict=True)]


def turn_phases(om: OcpModel, durations, nodes=NODES, free=None) -> list[Phase]:
    """A whole stride's six phases: the half stride's (:func:`gait_phases`, from the right
    heel strike) and their mirror (from the left's); ``durations`` and ``free`` per phase."""
    free = list(free or [None] * 6)
    half = gait_phases(om, durations[:3], nodes, free[:3])
    second = [Phase(float(d), tuple(_mirror_name(p) for p in ph.contacts), ph.intervals, f)
              for ph, d, f in zip(half, durations[3:], free[3:], strict=True)]  # fmt: skip
    return half + second


@dataclass
class TurnSolution:
    """A whole stride optimised along a circle (:mod:`humanoid.optimal.turn`).

    The stride starts at the right heel strike with the pelvis at x = 0, the circle's centre at
    (0, radius) (positive: turning left); its end is its start turned by :attr:`turn` about the
    centre. A walk laps it, each lap turned by :attr:`turn` more.

    Attributes:
        solution: The collocation's :class:`Solution` (the whole stride).
        gait: The straight cycle it bends (its body, speed and objective).
        radius: [m] of the pelvis's mean path.
        nodes: collocation intervals per phase (six phases).
    """

    solution: Solution
    gait: GaitSolution
    radius: float
    nodes: tuple = NODES + NODES

    def __repr__(self) -> str:
        s = self.solution
        return (f"TurnSolution({self.objective}, radius {self.radius:g} m, {self.speed:.2f} "
                f"m/s, {self.cadence:.1f} steps/min, {s.status}, {s.iterations} "
                "iterations)")  # fmt: skip

    @property
    def om(self) -> OcpModel:
        return self.gait.om

    @property
    def speed(self) -> float:
        """[m/s] along the circle (the straight cycle's)."""
        return abs(self.turn * self.radius) / self.period

    @property
    def objective(self) -> str:
        return self.gait.objective

    @property
    def period(self) -> float:
        return float(self.solution.t[-1])

    @property
    def turn(self) -> float:
        """[rad] the heading's change over a stride (the arc over the radius)."""
        s = self.solution
        return float(s.x[-1, 3] - s.x[0, 3])

    @property
    def step_length(self) -> float:
        """[m] half the stride's arc."""
        return self.speed * self.period / 2

    @property
    def cadence(self) -> float:
        return 120.0 / self.period

    def stride(self):
        """The whole stride: (t, x, v, forces), as :meth:`GaitSolution.stride` gives them."""
        s = self.solution
        return s.t, s.x, s.v, s.forces

    def contact_sets(self) -> list:
        """The contact points down in each collocation interval."""
        return interval_sets(turn_phases(self.om, self.solution.durations, self.nodes[:3]))

    def lapped(self, x, v, a, laps: int):
        """(x, v, a) of the OCP model turned ``laps`` strides on: the root's position about the
        circle's centre and its yaw."""
        theta = laps * self.turn
        R = rotation(theta)
        x, v, a = x.copy(), v.copy(), a.copy()
        x[:2] = R @ (x[:2] - (0.0, self.radius)) + (0.0, self.radius)
        x[3] += theta
        v[:2], a[:2] = R @ v[:2], R @ a[:2]
        return x, v, a


def check_radius(radius) -> float:
    """``radius`` [m] as a float if a turn can be optimised along it (at least
    :data:`MIN_RADIUS` either way).

    Raises:
        OptimalControlError: it cannot.
    """
    try:
        r = float(radius)
    except (TypeError, ValueError):
        r = math.nan
    if not (math.isfinite(r) and abs(r) >= MIN_RADIUS):
        raise OptimalControlError(
            f"a circle's radius must be finite and at least {MIN_RADIUS} m, got {radius}"
        )
    return r


def rotation(theta: float) -> np.ndarray:
    """The 2 x 2 rotation by ``theta`` [rad]."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def interval_sets(phases) -> list[set]:
    """The contact points down in each collocation interval of ``phases``."""
    return [set(ph.contacts) for ph in phases for _ in range(ph.intervals)]


def _mirror_name(p: str) -> str:
    if p.startswith("left"):
        return "right" + p[4:]
    return "left" + p[5:]


# -- storage -------------------------------------------------------------------------------
FORMAT = 1
# The objectives' revision, in every stored cycle's name: a cycle optimised under an earlier
# objective (a user's cache from an older version) is not found, and is solved again. Raise it
# whenever an objective or the problem changes (3: the knee's moment tracked).
REVISION = 3
# The turns' own revision, in their names besides the cycle's (2: the second double support's
# event is tracked too; 3: at the straight cycle's speed, in a narrower friction pyramid)
TURN_REVISION = 3
DATA = Path(__file__).resolve().parent.parent / "data" / "gaits"


def body_key(om: OcpModel) -> str:
    """A digest of the model's numbers (joints, placements, inertias, limits, frames): two
    bodies with one key have one optimal gait."""
    return model_key(om.model)


def gait_file(om: OcpModel, speed: float, objective: str) -> str:
    """The cache's file name of a body's gait at a speed (to the cm/s) and objective (and the
    objectives' :data:`REVISION`)."""
    return f"{body_key(om)}-{objective}-r{REVISION}-{round(100 * speed):03d}.npz"


def save_gait(g: GaitSolution, path) -> Path:
    """Write ``g`` to ``path`` (npz); :func:`load_gait` reads it."""
    meta = {"speed": g.speed, "objective": g.objective, "names": list(g.om.names),
            "body": body_key(g.om), "nodes": list(g.nodes)}  # fmt: skip
    return _write(g.solution, meta, path)


def load_gait(path, h) -> GaitSolution:
    """Read a gait :func:`save_gait` wrote, for the body ``h`` it was optimised for.

    Raises:
        OptimalControlError: the file is not such a gait, or it belongs to another body.
    """
    om = build_ocp_model(h)
    sol, meta = _read(path, body_key(om), "gait")
    points = {s: contact_points(om, s) for s in ("left", "right")}
    return GaitSolution(sol, om, meta["speed"], meta["objective"], points, tuple(meta["nodes"]))


def _write(s: Solution, meta: dict, path) -> Path:
    """A solution and what it is (``meta``) to an npz file, written whole or not at all."""
    points = sorted(s.forces)
    meta = {
        **meta, "format": FORMAT, "status": s.status, "success": s.success,
        "iterations": s.iterations, "seconds": s.seconds, "defect": s.defect,
        "dynamics": s.dynamics, "objective_value": s.objective, "terms": s.terms,
        "points": points,
    }  # fmt: skip
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    with open(tmp, "wb") as fh:
        np.savez_compressed(
            fh, t=s.t, x=s.x, v=s.v, a=s.a, tau=s.tau, durations=s.durations,
            forces=np.stack([s.forces[p] for p in points]), meta=json.dumps(meta),
        )  # fmt: skip
    tmp.replace(path)
    return path


def _read(path, body: str, what: str, cycle: str | None = None) -> tuple[Solution, dict]:
    """What :func:`_write` wrote, checked to be the body ``body``'s (its key) and, if given,
    made for the gait cycle whose digest is ``cycle``."""
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(str(arrays.pop("meta")))
    except (OSError, ValueError, KeyError) as exc:
        raise OptimalControlError(f"{path}: not a saved {what} ({exc})") from exc
    if meta.get("format") != FORMAT:
        raise OptimalControlError(f"{path}: {what} format {meta.get('format')}, expected {FORMAT}")
    if meta["body"] != body:
        raise OptimalControlError(f"{path}: the {what} of another body ({meta['body']})")
    if cycle is not None and meta.get("cycle") != cycle:
        raise OptimalControlError(f"{path}: a {what} of another gait cycle")
    forces = dict(zip(meta["points"], arrays["forces"], strict=True))
    sol = Solution(
        arrays["t"], arrays["x"], arrays["v"], arrays["a"], arrays["tau"], forces,
        arrays["durations"], meta["success"], meta["status"], meta["iterations"],
        meta["seconds"], meta["defect"], meta["dynamics"], meta["objective_value"],
        meta["terms"],
    )  # fmt: skip
    return sol, meta


def transition_file(gait: GaitSolution, kind: str) -> str:
    """The cache's file name of a start or stop (``kind``) into or out of ``gait``."""
    return gait_file(gait.om, round(gait.speed, 2), gait.objective).replace(".npz", f"-{kind}.npz")


def _digest(gait: GaitSolution) -> str:
    """The cycle's own digest: a transition stored for it meets no other."""
    return hashlib.sha256(np.ascontiguousarray(gait.solution.x).tobytes()).hexdigest()[:16]


def save_transition(tr: Transition, path) -> Path:
    """Write ``tr`` to ``path`` (npz); :func:`load_transition` reads it."""
    meta = {"kind": tr.kind, "body": body_key(tr.gait.om), "cycle": _digest(tr.gait)}
    return _write(tr.solution, meta, path)


def load_transition(path, gait: GaitSolution) -> Transition:
    """Read a transition :func:`save_transition` wrote, into or out of ``gait``.

    Raises:
        OptimalControlError: the file is not such a transition, or it meets another cycle.
    """
    sol, meta = _read(path, body_key(gait.om), "transition", _digest(gait))
    kind = meta["kind"]
    return Transition(kind, sol, gait, tuple(transition_phases(gait, kind)))


def stored_transition(gait: GaitSolution, kind: str) -> Transition | None:
    """The start or stop of ``gait`` from the user's cache or the package's data, or None if
    neither has one for this very cycle."""
    if kind not in KINDS:
        raise OptimalControlError(f"a transition is one of {KINDS}, got {kind!r}")
    return _found(transition_file(gait, kind), lambda path: load_transition(path, gait))


def _found(name: str, load):
    """``load(path)`` of the file ``name`` in the user's cache, else in the package's data;
    None if neither has one that loads (made for an earlier cycle at this speed)."""
    for folder in (cache_dir(), DATA):
        path = folder / name
        if path.is_file():
            try:
                return load(path)
            except HumanoidError:
                continue
    return None


def turn_file(gait: GaitSolution, radius: float) -> str:
    """The cache's file name of ``gait`` bent onto a circle of ``radius`` (to the cm)."""
    return gait_file(gait.om, round(gait.speed, 2), gait.objective).replace(
        ".npz", f"-turn{round(100 * radius):+05d}-t{TURN_REVISION}.npz")  # fmt: skip


def save_turn(turn: TurnSolution, path) -> Path:
    """Write ``turn`` to ``path`` (npz); :func:`load_turn` reads it."""
    meta = {"radius": turn.radius, "body": body_key(turn.om), "cycle": _digest(turn.gait),
            "nodes": list(turn.nodes)}  # fmt: skip
    return _write(turn.solution, meta, path)


def load_turn(path, gait: GaitSolution) -> TurnSolution:
    """Read a turn :func:`save_turn` wrote, of the straight ``gait``.

    Raises:
        OptimalControlError: the file is not such a turn, or it bends another cycle.
    """
    sol, meta = _read(path, body_key(gait.om), "turn", _digest(gait))
    return TurnSolution(sol, gait, float(meta["radius"]), tuple(meta["nodes"]))


def stored_turn(gait: GaitSolution, radius: float) -> TurnSolution | None:
    """``gait`` along a circle of ``radius`` from the user's cache or the package's data, or
    None if neither has it for this very cycle."""
    return _found(turn_file(gait, radius), lambda path: load_turn(path, gait))


def cache_dir() -> Path:
    """Where optimised gaits are kept: ``$HUMANOID_CACHE/gaits``, or ``~/.cache/humanoid/gaits``."""
    return user_cache("gaits")


def stored(om: OcpModel, objective: str) -> dict:
    """Saved gaits of this body and objective: {speed: path}, the package's first."""
    key = body_key(om)
    out = {}
    for folder in (cache_dir(), DATA):
        pattern = f"{key}-{objective}-r{REVISION}-*.npz"
        for path in sorted(folder.glob(pattern)) if folder.is_dir() else ():
            tail = path.stem.rsplit("-", 1)[1]
            if tail.isdigit():  # (not a transition's: see transition_file)
                out[int(tail) / 100] = path
    return out


def default_speed(h) -> float:
    """The body's free speed to the cm/s (the cache's resolution) [m/s]."""
    from ..walking.norms import free_speed
    from ..walking.reference import leg_length

    return round(free_speed(leg_length(h)), 2)


def stored_gait(h, speed=None, objective: str = "tracking") -> GaitSolution | None:
    """The body's gait at ``speed`` (default its free speed, to the cm/s) from the user's cache
    or the package's data, or None if neither has it."""
    if objective not in OBJECTIVES:
        raise OptimalControlError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    speed = round(default_speed(h) if speed is None else float(speed), 2)
    path = stored(build_ocp_model(h), objective).get(speed)
    return None if path is None else load_gait(path, h)
