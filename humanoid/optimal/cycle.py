"""An optimised gait cycle as data: what a collocation solved (:class:`Solution`), a half
stride of a gait (:class:`GaitSolution`) and its storage (:func:`save_gait`, :func:`load_gait`,
the package's cycles and the user's cache: :func:`stored_gait`).

Needs numpy and Pinocchio only, not casadi: a walk reads a shipped or cached cycle without the
optimal-control extra (:mod:`.gait` optimises one, with casadi).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import HumanoidError
from .coordinates import OcpModel, build_ocp_model

__all__ = [
    "REVISION", "SHIPPED_SPEEDS", "GaitSolution", "Phase", "Solution", "body_key", "cache_dir",
    "contact_points", "default_speed", "gait_file", "gait_phases", "load_gait", "save_gait",
    "stored", "stored_gait",
]  # fmt: skip

NODES = (5, 12, 8)  # collocation intervals in the three phases
OBJECTIVES = ("tracking", "predictive")
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
        raise HumanoidError(
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
        phases = gait_phases(self.om, self.solution.durations, self.nodes)
        half = [set(ph.contacts) for ph in phases for _ in range(ph.intervals)]
        return half + [{_mirror_name(p) for p in c} for c in half]

    def foot_forces(self):
        """(t, {side: (N, 3) summed force [N]}) over the stride."""
        t, _, _, forces = self.stride()
        out = {}
        for side in ("left", "right"):
            out[side] = sum(f for p, f in forces.items() if p.startswith(side))
        return t, out


def _mirror_name(p: str) -> str:
    if p.startswith("left"):
        return "right" + p[4:]
    return "left" + p[5:]


# -- storage -------------------------------------------------------------------------------
FORMAT = 1
# The objectives' revision, in every stored cycle's name: a cycle optimised under an earlier
# objective (a user's cache from an older version) is not found, and is solved again. Raise it
# whenever an objective or the problem changes.
REVISION = 2
DATA = Path(__file__).resolve().parent.parent / "data" / "gaits"


def body_key(om: OcpModel) -> str:
    """A digest of the model's numbers (joints, placements, inertias, limits, frames): two
    bodies with one key have one optimal gait."""
    m = om.model
    parts = []
    for j in range(1, m.njoints):
        M, inertia = m.jointPlacements[j], m.inertias[j]
        parts += [m.names[j], m.joints[j].shortname(), M.homogeneous.ravel(), inertia.mass,
                  inertia.lever, inertia.inertia.ravel()]  # fmt: skip
    parts += [m.lowerPositionLimit, m.upperPositionLimit, m.effortLimit, m.damping]
    for f in m.frames:
        parts += [f.name, f.parentJoint, f.placement.homogeneous.ravel()]
    text = "|".join(
        np.array2string(np.round(np.asarray(p, dtype=float), 9), threshold=10**6)
        if not isinstance(p, str) else p
        for p in parts
    )  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def gait_file(om: OcpModel, speed: float, objective: str) -> str:
    """The cache's file name of a body's gait at a speed (to the cm/s) and objective (and the
    objectives' :data:`REVISION`)."""
    return f"{body_key(om)}-{objective}-r{REVISION}-{round(100 * speed):03d}.npz"


def save_gait(g: GaitSolution, path) -> Path:
    """Write ``g`` to ``path`` (npz); :func:`load_gait` reads it."""
    s = g.solution
    points = sorted(s.forces)
    meta = {
        "format": FORMAT, "speed": g.speed, "objective": g.objective, "status": s.status,
        "success": s.success, "iterations": s.iterations, "seconds": s.seconds,
        "defect": s.defect, "dynamics": s.dynamics, "objective_value": s.objective,
        "terms": s.terms, "points": points, "names": list(g.om.names),
        "body": body_key(g.om), "nodes": list(g.nodes),
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


def load_gait(path, h) -> GaitSolution:
    """Read a gait :func:`save_gait` wrote, for the body ``h`` it was optimised for.

    Raises:
        HumanoidError: the file is not such a gait, or it belongs to another body.
    """
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(str(arrays.pop("meta")))
    except (OSError, ValueError, KeyError) as exc:
        raise HumanoidError(f"{path}: not a saved gait ({exc})") from exc
    if meta.get("format") != FORMAT:
        raise HumanoidError(f"{path}: gait format {meta.get('format')}, expected {FORMAT}")
    om = build_ocp_model(h)
    if meta["body"] != body_key(om):
        raise HumanoidError(f"{path}: the gait of another body ({meta['body']})")
    forces = dict(zip(meta["points"], arrays["forces"], strict=True))
    sol = Solution(
        arrays["t"], arrays["x"], arrays["v"], arrays["a"], arrays["tau"], forces,
        arrays["durations"], meta["success"], meta["status"], meta["iterations"],
        meta["seconds"], meta["defect"], meta["dynamics"], meta["objective_value"],
        meta["terms"],
    )  # fmt: skip
    points = {s: contact_points(om, s) for s in ("left", "right")}
    return GaitSolution(sol, om, meta["speed"], meta["objective"], points, tuple(meta["nodes"]))


def cache_dir() -> Path:
    """Where optimised gaits are kept: ``$HUMANOID_CACHE/gaits``, or ``~/.cache/humanoid/gaits``."""
    root = os.environ.get("HUMANOID_CACHE")
    return (Path(root) if root else Path.home() / ".cache" / "humanoid") / "gaits"


def stored(om: OcpModel, objective: str) -> dict:
    """Saved gaits of this body and objective: {speed: path}, the package's first."""
    key = body_key(om)
    out = {}
    for folder in (cache_dir(), DATA):
        pattern = f"{key}-{objective}-r{REVISION}-*.npz"
        for path in sorted(folder.glob(pattern)) if folder.is_dir() else ():
            out[int(path.stem.rsplit("-", 1)[1]) / 100] = path
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
        raise HumanoidError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    speed = round(default_speed(h) if speed is None else float(speed), 2)
    path = stored(build_ocp_model(h), objective).get(speed)
    return None if path is None else load_gait(path, h)
