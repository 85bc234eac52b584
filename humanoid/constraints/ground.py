"""Ground contact for every body: rigid, unilateral, with Coulomb friction, on the floor z = 0.

Built on what Pinocchio 4.1 and coal ship (the design of Inria's Simple simulator):

- **Detection.** The candidate points of the body's collision geometries (our primitives;
  meshes as their convex hulls) are the points of each shape that can be lowest: the vertices
  of a box or a convex hull, the lowest point of a sphere, of each end of a capsule and of each
  rim of a cylinder, and samples around the rims (a cylinder standing on its end). All are
  placed at once each step from their joints' placements (one product, no Python loop over
  points), and those within the margin of the floor become contacts. (coal's contact patches
  project their points onto one plane, so a tilted box would rest on its projected corners.) A
  point that a body and its parent share (the rearfoot's front corners and the toes' rear
  ones, at an MTP angle near zero) is the child's alone while the two are within a millimetre.
- **Constraints.** Each contact is a point of the body against the floor, world axes (tangent
  x, y, normal z), with a Coulomb friction cone of coefficient mu. Its Jacobian is the point's
  velocity from its joint's world Jacobian, v_p = v_O + w x p, all points in one product (the
  same as Pinocchio's ``PointContactConstraintModel``: tests/test_ground.py); Pinocchio's
  solver reads the cones from pooled constraint models.
- **Solve.** Velocity level, one solve per time step: with v_free the velocity after the step
  without contacts, find impulses lambda in the friction cones with sigma = G lambda + g in the
  dual cones and lambda . sigma = 0, G = J M^-1 J^T the Delassus operator and
  g = J v_free + phi / dt on the normal rows (phi: the signed distance; a point not yet touching
  may close its gap within the step, never more: speculative contact; a point below the floor is
  pushed out by a fraction of its depth per step). Pinocchio's ``ADMMConstraintSolver`` solves
  this nonlinear complementarity problem (with the De Saxce correction: true Coulomb friction,
  sticking, sliding and lift-off; impacts are inelastic). Then v+ = v_free + M^-1 J^T lambda.

Unilateral rows of our own (joint ranges, :mod:`humanoid.constraints.limits`) join the same
solve: their cone is the non-negative orthant.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import coal
import numpy as np
import pinocchio as pin

# the compiled kernels (humanoid/kernels.c), None without a C compiler: the NumPy paths then
from ..dynamics import KERNELS, kernel_tree
from ..errors import ModelError, SceneError
from ..linalg import cross
from ..variants import CONTACT_SOLVERS

__all__ = ["SPECULATIVE_SPEED", "ContactSolver", "Ground", "GroundSettings"]

# ADMM tolerances: contact impulses of a 1 ms step are O(1e-3 .. 1) N s, so Pinocchio's 1e-6
# default would be loose.
TOLERANCE = 1e-9


# [m/s] a scene's ground takes as candidates the points within this speed times its step of the
# floor (or its margin, if wider): a point approaching slower is found before it reaches the
# floor, and the step's velocity-level contact (its gap closed within the step) stops it there.
# At the default 1 ms step the margin's 1 cm is wider; at 8 ms a fixed 1 cm let the drop's body
# (landing at 3.1 m/s) into the floor 15 mm before its contacts were found.
SPECULATIVE_SPEED = 5.0


@dataclass(frozen=True)
class GroundSettings:
    """Contact parameters.

    Attributes:
        mu: Coulomb friction coefficient.
        margin: [m] points closer than this to the floor are contact candidates.
        correction: Fraction of a penetration removed per step (0..1).
        tolerance: ADMM feasibility and complementarity tolerances.
        max_iterations: ADMM iteration cap per solve.
        lanczos: Lanczos iterations of ADMM's estimate of the Delassus operator's spectrum
            (Pinocchio's default, the problem's size, cost 600 us of 700 on 31 contacts; the
            iterations the solves took were the same with 10 and 30 in every shipped scene).
        anderson: Anderson acceleration's memory (0: none, the default). Iterations a step
            without it and with 3: balance 314 and 39, collapse 118 and 72, slide 80 and 59;
            but example-robot-data's human, whose walk is fragile (its solves stop at the
            iteration cap in 13 % of its steps, either way), then fell at 4.1 s of its eight
            steps (3.4 s with 5): single runs of a walk later found chaotic (it fell there
            in 4 of 12 runs started 1e-6 m/s apart without Anderson acceleration).
        solver: ``"kernel"`` (the default): the project's ADMM, compiled
            (humanoid/kernels.c), started from the last step's impulses at the same points of
            the body and the same range rows, with Anderson acceleration; it stops on the
            problem's own residual, and hands a step it does not solve within
            :data:`KERNEL_ITERATIONS` to Pinocchio's ADMM. ``"admm"``: Pinocchio's ADMM from
            zero at every step. ``"pgs"``: Pinocchio's projected Gauss-Seidel on the same
            problem, the same tolerances (its over-relaxation 1). On the same 1000 solves of
            the drop (19 rows) PGS took 3 times ADMM's iterations and twice its time, on the
            person's walk's (16 rows) 2.8 and 2.6 times: the work-precision chart of
            ``humanoid bench accuracy`` shows all three.
    """

    mu: float = 0.8
    margin: float = 0.01
    correction: float = 0.2
    tolerance: float = TOLERANCE
    max_iterations: int = 1000
    lanczos: int = 10
    anderson: int = 0
    solver: str = "kernel"


# the compiled ADMM (solver "kernel"): its iterations before it hands a step to Pinocchio's,
# its penalty (the rows scaled to a unit diagonal) and its Anderson memory. Measured on the
# first 2 s of the falls at their tolerance, 1e-7 (`humanoid bench step`'s scenes): mean
# iterations and steps handed over of 2000, drop 17.4 and 7, collapse 13.4 and 14, slide 9.1
# and 4; at 1e-6 without Anderson (and no rows left out), 26.5 and 86, 32.7 and 198, 15.8 and
# 181. A penalty of 0.3 or 3 instead of 1 handed over 2 to 4 times as many. The whole drop
# (6 s) with 100 iterations handed 284 steps over, and Pinocchio's ADMM capped 11 of them;
# with 300, 42 and none.
KERNEL_ITERATIONS = 300
KERNEL_RHO = 1.0
KERNEL_ANDERSON = 3
# rows whose free motion keeps them off the floor (or off their limit) by more than this
# [m/s, rad/s] are left out of the solve, and the step solved again with them if the solution
# brings one through. Measured on the falls' first 2 s (steps solved again of 2000, us a step):
# 0 (left out whenever the free motion keeps them off at all): 1040-1265, drop 205, collapse
# 172, slide 210; 0.01: 542-916; 0.05: 70-143; 0.1: 3-5, 156, 155, 209; 0.5: 1-2, 153, 155,
# 210; 1.0: 0-1, 154, 152, 245; none left out: drop 169, collapse 254, slide 365. At 0.1 and
# 0.3, example-robot-data's human fell at 4.1 s of its 8-step walk of tests/test_gait.py, at
# 0.5, 1.0 and with none left out it completed; but that walk was chaotic then (at 0.5 it fell
# there in 4 of 12 runs started 1e-6 m/s apart, before TrackingGains.placement_behind), so
# those single runs do not tell the thresholds apart: 0.5 rests on the counts and costs.
KERNEL_SCREEN = 0.5
# each of humanoid.variants.CONTACT_SOLVERS: Pinocchio's solver, its settings and its result
CONIC_SOLVERS = {
    # the compiled ADMM (ContactSolver._kernel_solve), with Pinocchio's ADMM where it hands over
    "kernel": (pin.ADMMConstraintSolver, pin.ADMMSolverSettings, pin.ADMMSolverResult),
    "admm": (pin.ADMMConstraintSolver, pin.ADMMSolverSettings, pin.ADMMSolverResult),
    "pgs": (pin.PGSConstraintSolver, pin.PGSSolverSettings, pin.PGSSolverResult),
}
RIM_SAMPLES = 8  # points sampled around each rim of a cylinder
MAX_POINTS = 8  # contacts kept per geometry (the extremes of its support polygon)
DEPTH_WEIGHT = 10.0  # in choosing them, 1 mm lower counts as 1 cm further out


def _convex(shape):
    """A mesh's convex hull (its vertices are the candidate points; coal's collision of a
    triangle mesh against a halfspace is unreliable); primitives as they are."""
    if isinstance(shape, coal.BVHModelBase):
        shape.buildConvexHull(True, "Qt")
        return shape.convex
    return shape


class _Shape:
    """Candidate contact points of one geometry: fixed points in the joint frame (vertices,
    rim samples) and round parts whose lowest point moves (sphere centres with their radius,
    rims as centre, axis and radius)."""

    def __init__(self, g: pin.GeometryObject) -> None:
        shape, M = g.geometry, g.placement
        self.joint = g.parentJoint
        self.fixed = np.zeros((0, 3))
        self.spheres: list[tuple[np.ndarray, float]] = []  # (centre in the joint frame, radius)
        self.rims: list[tuple[np.ndarray, np.ndarray, float]] = []  # (centre, axis, radius)
        R, t = M.rotation, M.translation
        if isinstance(shape, coal.Box):
            h = np.asarray(shape.halfSide)
            corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
            self.fixed = (corners * h) @ R.T + t
        elif isinstance(shape, coal.ConvexBase):
            pts = np.array(shape.points())  # all the hull's vertices at once
            self.fixed = _support_points(pts) @ R.T + t
        elif isinstance(shape, coal.Sphere):
            self.spheres.append((t.copy(), float(shape.radius)))
        elif isinstance(shape, coal.Capsule):
            for s in (-1.0, 1.0):
                self.spheres.append((t + s * shape.halfLength * R[:, 2], float(shape.radius)))
        elif isinstance(shape, coal.Cylinder):
            ang = np.linspace(0.0, 2 * np.pi, RIM_SAMPLES, endpoint=False)
            ring = np.column_stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)]) * shape.radius
            for s in (-1.0, 1.0):
                centre = t + s * shape.halfLength * R[:, 2]
                self.rims.append((centre, R[:, 2].copy(), float(shape.radius)))
                self.fixed = np.vstack([self.fixed, ring @ R.T + centre])
        else:
            raise ModelError(f"no contact points for a {type(shape).__name__} ({g.name})")

    def placed(self, oMi: pin.SE3) -> np.ndarray:
        """World positions of the fixed points, the joint at ``oMi``."""
        return self.fixed @ oMi.rotation.T + oMi.translation


class _Candidates:
    """Every shape's candidate points as flat arrays, placed all at once (one placement read
    per joint, no Python loop over points): fixed points (vertices), sphere bottoms and rim
    bottoms, each with its shape and its index in the shape (fixed points first, then its
    spheres, then its rims): the contacts come out geometry by geometry, in that order."""

    def __init__(self, shapes: list[_Shape]) -> None:
        self.joints = np.unique([s.joint for s in shapes]).astype(int)
        slot = {int(j): k for k, j in enumerate(self.joints)}
        # one row per point: (slot of its joint, shape, index in the shape, local point), the
        # fixed points of every shape first, then the sphere centres, then the rim centres
        fixed, spheres, rims = [], [], []
        for i, s in enumerate(shapes):
            n0, n1, j = len(s.fixed), len(s.fixed) + len(s.spheres), slot[s.joint]
            fixed += [(j, i, k, p) for k, p in enumerate(s.fixed)]
            spheres += [(j, i, n0 + k, c) for k, (c, _) in enumerate(s.spheres)]
            rims += [(j, i, n1 + k, c) for k, (c, _, _) in enumerate(s.rims)]
        rows = fixed + spheres + rims
        self._slot, self._shape, self._index = (np.array([x[k] for x in rows], dtype=int)
                                                for k in range(3))  # fmt: skip
        self._local = np.array([x[3] for x in rows]).reshape(-1, 3)
        self._sphere = np.arange(len(fixed), len(fixed) + len(spheres))
        self._round = len(fixed) + len(spheres)  # the rims' rows start here
        self.s_radius = np.array([r for s in shapes for _, r in s.spheres])
        self.r_slot = self._slot[self._round :]
        self.r_axis = np.array([a for s in shapes for _, a, _ in s.rims]).reshape(-1, 3)
        self.r_radius = np.array([r for s in shapes for *_, r in s.rims])
        self.offset = np.cumsum([0] + [len(s.fixed) for s in shapes])  # shape -> first fixed row

    def place(self, data: pin.Data):
        """(R (u, 3, 3), t (u, 3)): the placements of the shapes' joints."""
        oMi = data.oMi
        placed = [oMi[int(j)] for j in self.joints]
        return (np.array([M.rotation for M in placed]).reshape(-1, 3, 3),
                np.array([M.translation for M in placed]).reshape(-1, 3))  # fmt: skip

    def lowest(self, R: np.ndarray, t: np.ndarray):
        """(world points (N, 3), shape (N,), index in the shape (N,), slot of the joint (N,)):
        the fixed points placed, each sphere's and each rim's lowest point (a rim lying flat
        has none: its samples are fixed points)."""
        slot = self._slot
        world = np.einsum("nij,nj->ni", R[slot], self._local) + t[slot]
        n = self._round
        world[self._sphere, 2] -= self.s_radius
        if not len(self.r_slot):
            return world, self._shape, self._index, slot
        axis = np.einsum("nij,nj->ni", R[self.r_slot], self.r_axis)
        d = axis[:, 2:3] * axis  # down - (down . axis) axis, down = (0, 0, -1)
        d[:, 2] -= 1.0
        norm = np.linalg.norm(d, axis=1)
        ok = norm > 1e-9
        world[n:] += (self.r_radius / np.where(ok, norm, 1.0))[:, None] * d
        keep = np.concatenate([np.ones(n, dtype=bool), ok])
        return world[keep], self._shape[keep], self._index[keep], slot[keep]


SUPPORT_DIRECTIONS = 256  # a convex hull keeps its support points in this many directions


def _support_points(points: np.ndarray, n: int = SUPPORT_DIRECTIONS) -> np.ndarray:
    """The points of a convex hull that are extreme in one of n directions spread evenly over
    the sphere (a Fibonacci lattice): a scanned or smooth mesh's hull has thousands of
    vertices, and the lowest point of the body in any orientation is one of these to within
    the hull's curvature over the lattice's spacing (about 13 deg)."""
    if len(points) <= n:
        return points
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    r = np.sqrt(1.0 - z * z)
    phi = np.pi * (1.0 + 5.0**0.5) * k
    dirs = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    return points[np.unique(np.argmax(points @ dirs.T, axis=0))]


def _extremes(points: np.ndarray, n: int) -> np.ndarray:
    """Indices of at most n + 1 points that span the support polygon: the extremes in the
    horizontal plane along n directions (a flat mesh face may bring dozens of coplanar
    points; its contact is its outline), and the lowest point."""
    if len(points) <= n:
        return np.arange(len(points))
    ang = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    dirs = np.column_stack([np.cos(ang), np.sin(ang)])
    # outermost, but low first: a bevelled sole's outermost points sit millimetres up its
    # bevel, and the flat bottom's corners are what the floor meets (1 mm of height weighs
    # as 1 cm of reach); and the lowest point (a rounded surface's outline lies above it)
    z = points[:, 2] - points[:, 2].min()
    score = points[:, :2] @ dirs.T - DEPTH_WEIGHT * z[:, None]
    return np.unique([*np.argmax(score, axis=0), np.argmin(points[:, 2])])


SHARED = 1e-3  # [m] a parent's point this near its child's is the child's alone


def _skew_terms() -> np.ndarray:
    """(3, 9): p @ _SKEW is the skew matrix [p]x of each row p, flattened."""
    E = np.zeros((3, 3, 3))
    for k, i, j in ((0, 2, 1), (1, 0, 2), (2, 1, 0)):  # [p]x = [[0, -z, y], [z, 0, -x], ...]
        E[k, i, j], E[k, j, i] = 1.0, -1.0
    return E.reshape(3, 9)


_SKEW = _skew_terms()


def _shared_corners(model: pin.Model, shapes) -> list[tuple[int, int, np.ndarray, np.ndarray]]:
    """The points that a body's geometry and its child body's have in common at the neutral
    configuration (a foot's front corners and its toes' rear ones on the MTP axis): (parent
    shape, child shape, the parent's point indices, the child's matching ones)."""
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    world = [s.placed(data.oMi[s.joint]) for s in shapes]
    out = []
    for a, parent in enumerate(shapes):
        for b, child in enumerate(shapes):
            if model.parents[child.joint] != parent.joint or not len(world[a]) or not len(world[b]):
                continue
            d = np.linalg.norm(world[a][:, None, :] - world[b][None, :, :], axis=2)
            ia = np.flatnonzero(d.min(axis=1) < 1e-9)
            if len(ia):
                out.append((a, b, ia, d[ia].argmin(axis=1)))
    return out


def _kernel_plan(model: pin.Model, cand: _Candidates, shared, key: int):
    """The compiled kernel's copy of the model's tree and of the candidate points (sorted as
    :meth:`Ground._detect` returns them), or None if the kernel is not built or a joint is
    of a kind it does not place."""
    tree = kernel_tree(model)
    if tree is None:
        return None
    if KERNELS is None:
        warnings.warn("humanoid.kernels is not built (the package was installed without a C "
                      "compiler): the ground contact's detection runs on its NumPy path, "
                      "about ten times slower", RuntimeWarning, stacklevel=3)  # fmt: skip
        return None
    i64 = np.int64
    n = len(cand._slot)
    kind = np.zeros(n, dtype=i64)
    kind[cand._sphere], kind[cand._round :] = 1, 2
    radius, caxis = np.zeros(n), np.zeros((n, 3))
    radius[cand._sphere] = cand.s_radius
    radius[cand._round :], caxis[cand._round :] = cand.r_radius, cand.r_axis
    order = np.argsort(cand._shape * key + cand._index, kind="stable")
    rank = np.empty(n, dtype=i64)
    rank[order] = np.arange(n)
    pa, pb = (rank[shared[0]], rank[shared[1]]) if shared is not None else (np.zeros(0),) * 2
    ang = np.linspace(0.0, 2 * np.pi, MAX_POINTS, endpoint=False)
    dirs = np.column_stack([np.cos(ang), np.sin(ang)])
    arrays = list(tree)
    arrays += [
        np.ascontiguousarray(a, dtype=i64)
        for a in (cand.joints[cand._slot][order], kind[order], cand._shape[order])
    ]
    arrays += [np.ascontiguousarray(a, dtype=float)
               for a in (cand._local[order], radius[order], caxis[order])]  # fmt: skip
    arrays += [np.ascontiguousarray(a, dtype=i64) for a in (pa, pb)]
    arrays.append(np.ascontiguousarray(dirs))
    return KERNELS.ground_plan(model.njoints, model.nq, model.nv, n, len(pa), MAX_POINTS,
                               MAX_POINTS, DEPTH_WEIGHT, SHARED, *arrays)  # fmt: skip


@dataclass(frozen=True)
class GroundContacts:
    """The ground contacts of one configuration.

    Attributes:
        points: World points on the body, (n, 3) [m].
        phi: Their signed distances to the floor [m] (negative below it).
        joints: The joint each point is on, (n,).
        local: The points in their joint's frame, (n, 3) [m].
        rows: Their Jacobian, (3n, nv), when the compiled kernel found them (None: the NumPy
            path, which builds it from the joint Jacobians: :meth:`Ground.jacobian`).
        ids: Each contact's candidate point (the same point of the body from step to step;
            from the compiled kernel, else None).
    """

    points: np.ndarray
    phi: np.ndarray
    joints: np.ndarray
    local: np.ndarray
    rows: np.ndarray | None = field(default=None, compare=False, repr=False)
    ids: np.ndarray | None = field(default=None, compare=False, repr=False)

    def __len__(self) -> int:
        return len(self.phi)


_NO_CONTACTS = GroundContacts(np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=int),
                              np.zeros((0, 3)))  # fmt: skip


class Ground:
    """The floor z = 0 and the geometries that may touch it.

    Args:
        model: The Pinocchio model.
        geometry_model: Collision geometry (visual geometry for models that have none).
        geometries: Indices of the geometries that may touch the floor.
        settings: :class:`GroundSettings`.
        compiled: Detect with the compiled kernel (humanoid/kernels.c) when it is built and
            places every joint of the model; False: always the NumPy path (the same contacts:
            tests/test_kernels.py).

    Attributes:
        joints: The joints that carry those geometries.
        compiled: Whether :meth:`detect` runs the compiled kernel (given the configuration).
    """

    def __init__(self, model: pin.Model, geometry_model: pin.GeometryModel, geometries,
                 settings: GroundSettings = GroundSettings(), compiled: bool = True
                 ) -> None:  # fmt: skip
        self.settings = settings
        self.names, self.shapes = [], []
        for i in geometries:
            g = geometry_model.geometryObjects[i].copy()
            g.geometry = _convex(g.geometry)
            self.names.append(g.name)
            self.shapes.append(_Shape(g))
        self._candidates = _Candidates(self.shapes)
        self.joints = self._candidates.joints
        off = self._candidates.offset
        shared = _shared_corners(model, self.shapes)
        # the parents' and the children's fixed rows that are one point at MTP zero
        self._shared = (np.concatenate([off[a] + ia for a, _, ia, _ in shared]).astype(int),
                        np.concatenate([off[b] + ib for _, b, _, ib in shared]).astype(int)
                        ) if shared else None  # fmt: skip
        self._key = 1 + max((len(s.fixed) + len(s.spheres) + len(s.rims) for s in self.shapes),
                            default=0)  # fmt: skip
        # each joint's column mask in the world Jacobian (the joints it moves with)
        mask = np.zeros((model.njoints, model.nv))
        for j in range(1, model.njoints):
            for k in model.supports[j][1:]:
                jm = model.joints[k]
                mask[j, jm.idx_v : jm.idx_v + jm.nv] = 1.0
        self._mask = mask
        self._pool: list[tuple[pin.ConstraintModel, pin.ConstraintData]] = []
        self._model = model
        self._last: tuple | None = None  # ((model, configuration), contacts) of the last call
        # the compiled kernel's plan (None: the NumPy path); compiled=False keeps NumPy's
        self._plan = _kernel_plan(model, self._candidates, self._shared, self._key) \
            if compiled else None  # fmt: skip

    def cones(self, n: int) -> tuple[list, list]:
        """n friction-cone constraint models and their datas (pooled): what Pinocchio's solver
        reads of a contact is its cone (its size and mu), not its placement."""
        while len(self._pool) < n:
            pc = pin.PointContactConstraintModel(
                self._model, 0, pin.SE3.Identity(), 0, pin.SE3.Identity()
            )
            pc.setFriction(self.settings.mu)
            cm = pin.ConstraintModel(pc)
            self._pool.append((cm, cm.createData()))
        pool = self._pool[:n]
        return [cm for cm, _ in pool], [cd for _, cd in pool]

    def jacobian(self, data: pin.Data, contacts: GroundContacts) -> np.ndarray:
        """The contacts' Jacobian, (3n, nv), world axes (x, y, z rows per point): the velocity
        of each point of the body, v_p = v_O + w x p from the world Jacobian of its joint
        (``data`` must hold the joint Jacobians at the contacts' configuration:
        ``pin.computeJointJacobians``); or the rows the compiled kernel found with them."""
        if contacts.rows is not None:
            return contacts.rows
        n = len(contacts)
        if not n:
            return np.zeros((0, self._model.nv))
        J = data.J
        skew = (contacts.points @ _SKEW).reshape(n, 3, 3)  # [p]x, so w x p = -[p]x w
        rows = (J[:3] - skew @ J[3:]) * self._mask[contacts.joints][:, None, :]
        return rows.reshape(3 * n, -1)

    def detect(self, model: pin.Model, data: pin.Data, at=None) -> GroundContacts:
        """Contacts of the current placements (``data.oMi`` must be up to date).

        ``at``: the configuration the placements are at. Given, a call at the same model and
        configuration as the last one returns its contacts again without detecting them: a
        controller and its plant detect at the same state every tick (a person's walk spent
        0.37 ms a tick in each).
        """
        key = None if at is None else (model, np.asarray(at, dtype=float).tobytes())
        last = self._last
        if key is not None and last is not None and last[0][0] is model and last[0][1] == key[1]:
            return last[1]
        found = self._detect(data) if key is None or self._plan is None else self._compiled(at)
        self._last = None if key is None else (key, found)
        return found

    @property
    def compiled(self) -> bool:
        return self._plan is not None

    def _compiled(self, q) -> GroundContacts:
        """:meth:`_detect`'s contacts from the compiled kernel, at q, with their Jacobian."""
        assert KERNELS is not None
        q = np.ascontiguousarray(q, dtype=float)
        n = KERNELS.ground_select(self._plan, q, self.settings.margin)
        points, local = np.empty((n, 3)), np.empty((n, 3))
        joints, rows = np.empty(n, dtype=np.int64), np.empty((3 * n, self._model.nv))
        ids = np.empty(n, dtype=np.int64)
        KERNELS.ground_write(self._plan, points, joints, local, rows, ids)
        found = GroundContacts(points, points[:, 2].copy(), joints, local, rows, ids)
        for a in (points, found.phi, joints, local, rows, ids):
            a.flags.writeable = False
        return found

    def _detect(self, data: pin.Data) -> GroundContacts:
        """:meth:`detect`'s contacts, found: every candidate point placed at once; those within
        the margin of the floor, less a parent's points that are its child's now; at most
        :data:`MAX_POINTS` + 1 per geometry (its support polygon's extremes)."""
        cand = self._candidates
        R, t = cand.place(data)
        pts, shape, index, slot = cand.lowest(R, t)
        keep = pts[:, 2] < self.settings.margin
        if self._shared is not None:
            pa, pb = self._shared  # rows of the fixed points, first in pts
            near = np.linalg.norm(pts[pa] - pts[pb], axis=1) < SHARED
            keep[pa[near]] = False
        keys = shape * self._key + index
        rows = np.flatnonzero(keep)
        rows = rows[np.argsort(keys[rows], kind="stable")]  # per geometry, in its order
        counts = np.bincount(shape[rows], minlength=len(self.shapes))
        if counts.max(initial=0) > MAX_POINTS:
            parts = []
            for s in np.unique(shape[rows]):
                mine = rows[shape[rows] == s]
                parts.append(mine[_extremes(pts[mine], MAX_POINTS)] if len(mine) > MAX_POINTS
                             else mine)  # fmt: skip
            rows = np.concatenate(parts)
        p = pts[rows]
        sl = slot[rows]
        local = np.einsum("nji,nj->ni", R[sl], p - t[sl])  # R^T (p - t)
        found = GroundContacts(p, p[:, 2].copy(), cand.joints[sl], local)
        for a in (found.points, found.phi, found.joints, found.local):
            a.flags.writeable = False  # (detect hands the same record to plant and controller)
        return found


@dataclass(frozen=True)
class StepContacts:
    """What the contact solve of one step found.

    Attributes:
        points: World points of the ground contacts on the body, (n, 3) [m].
        phi: Their signed distances to the floor [m] at the start of the step.
        impulses: Ground impulses per contact, world axes (n, 3) [N s].
        limit_impulses: Impulses of the active joint-range rows [N m s].
        limit_generalized: The same in generalised coordinates, J_r^T lambda, (nv,) [N m s]:
            divided by dt, the passive moment the ranges added to each joint in the step.
        iterations: ADMM iterations; converged: whether it met its tolerance.
        joints: The joint of the body each contact is on, (n,).
        local: The contacts' points in their joint's frame, (n, 3) [m].
    """

    points: np.ndarray
    phi: np.ndarray
    impulses: np.ndarray
    limit_impulses: np.ndarray
    iterations: int
    converged: bool
    joints: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    limit_generalized: np.ndarray | None = None
    local: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def force(self) -> np.ndarray:
        """Total ground impulse, world axes [N s] (divide by dt for the mean force)."""
        return self.impulses.sum(axis=0) if len(self.impulses) else np.zeros(3)

    @property
    def wrench(self) -> np.ndarray:
        """Total ground impulse and its moment about the world origin, the impulses acting at
        the points' projections on the floor (fx, fy, fz, tx, ty, tz) [N s, N m s]: the centre
        of pressure is (-ty / fz, tx / fz, 0)."""
        if not len(self.impulses):
            return np.zeros(6)
        floor = self.points * np.array([1.0, 1.0, 0.0])
        return np.concatenate([self.impulses.sum(axis=0),
                               cross(floor, self.impulses).sum(axis=0)])  # fmt: skip


class _WarmStart:
    """The last step's impulses by the point of the body they acted at (its ground candidate)
    and by the range row (a joint's limit): the next solve's start (zero where none was)."""

    def __init__(self, points: int, range_rows: int) -> None:
        self.points, self.ranges = np.zeros((points, 3)), np.zeros(range_rows)
        self._ids: tuple = (None, None)

    def start(self, point_ids, n: int, range_ids, m: int) -> np.ndarray:
        lam = np.zeros(m)
        if point_ids is not None and n:
            lam[: 3 * n] = self.points[point_ids].ravel()
        if range_ids is not None and m > 3 * n:
            lam[3 * n :] = self.ranges[range_ids]
        self._ids = (point_ids, range_ids)
        return lam

    def keep(self, lam: np.ndarray, n: int) -> None:
        point_ids, range_ids = self._ids
        self.points[:], self.ranges[:] = 0.0, 0.0
        if point_ids is not None and n:
            self.points[point_ids] = lam[: 3 * n].reshape(-1, 3)
        if range_ids is not None and len(range_ids):
            self.ranges[range_ids] = lam[3 * n :]


class ContactSolver:
    """One velocity-level step of the ground contacts and unilateral rows (joint ranges)."""

    def __init__(self, model: pin.Model, ground: Ground | None, ranges=None,
                 settings: GroundSettings = GroundSettings()) -> None:  # fmt: skip
        self.model, self.ground, self.ranges, self.settings = model, ground, ranges, settings
        if (why := CONTACT_SOLVERS.refusal(settings.solver)) is not None:
            raise SceneError(why)
        if settings.solver == "kernel" and KERNELS is None:
            warnings.warn('contact solver "kernel" needs humanoid.kernels, which was not built '
                          "(the package was installed without a C compiler): Pinocchio's ADMM "
                          "solves instead", RuntimeWarning, stacklevel=2)  # fmt: skip
            self.settings = settings = replace(settings, solver="admm")
        points = len(ground._candidates._slot) if ground is not None else 0
        self._warm = _WarmStart(points, ranges.max_rows if ranges is not None else 0)
        solver, solver_settings, result = CONIC_SOLVERS[settings.solver]
        self.solver, st, self.result = solver(), solver_settings(), result()
        if solver is pin.ADMMConstraintSolver:  # "admm", and "kernel"'s hand-over: the same
            st.admm_update_rule = pin.ADMMUpdateRule.SPECTRAL  # no iteration-cap hits on impacts
            st.lanczos_size = settings.lanczos
            st.anderson_capacity = settings.anderson
        st.absolute_feasibility_tol = st.relative_feasibility_tol = settings.tolerance
        st.absolute_complementarity_tol = st.relative_complementarity_tol = settings.tolerance
        st.max_iterations = settings.max_iterations
        self.solve_settings = st  # ADMM's or PGS's
        self._orthants: dict[int, tuple] = {}
        self.failures = 0
        self.fallbacks = 0  # solver "kernel": steps it handed to Pinocchio's ADMM

    def _orthant(self, n: int):
        """A constraint model whose cone is the non-negative orthant of size n: Pinocchio's
        solvers read each block's cone from a constraint model, and our own unilateral rows
        (ball-joint ranges) have none. A joint-limit model of a placeholder chain of n hinges,
        each at its lower limit, has exactly n rows with that cone; only its cone is used."""
        if n not in self._orthants:
            chain = pin.Model()
            parent = 0
            for i in range(n):
                parent = chain.addJoint(parent, pin.JointModelRX(), pin.SE3.Identity(), f"j{i}")
            lo, hi = -np.ones(n), np.ones(n)
            jl = pin.JointLimitConstraintModel(
                chain, list(range(1, n + 1)), lo, hi, np.full(n, 0.1)
            )
            jl.makeSelectionFilteredByLimitProximity(lo)
            cm = pin.ConstraintModel(jl)
            self._orthants[n] = (cm, cm.createData())
        return self._orthants[n]

    def step(self, q, v_free, dt: float, Minv: np.ndarray, data: pin.Data):
        """Contact impulses for a step from (q, v_free); returns (v+, StepContacts).

        ``data`` must hold the joint placements and Jacobians at q
        (``pin.computeJointJacobians``).
        """
        contacts, J, gap, n_limits = self._rows(q, dt, data)
        if J is None:
            none = np.zeros((0, 3))
            return v_free, StepContacts(none, np.zeros(0), none, np.zeros(0), 0, True,
                                        limit_generalized=np.zeros(self.model.nv))  # fmt: skip
        n_ground = len(contacts)
        if self.settings.solver == "kernel":
            solved = self._kernel_solve(J, gap, Minv, v_free, contacts)
        else:
            solved = self._pinocchio_solve(J, gap, Minv, v_free, n_ground, n_limits)
        lam, v_new, iterations, converged = solved
        if not converged:
            self.failures += 1
        impulses = lam[: 3 * n_ground].reshape(-1, 3)
        limits = lam[3 * n_ground :]
        generalized = J[3 * n_ground :].T @ limits if n_limits else np.zeros(self.model.nv)
        out = StepContacts(contacts.points, contacts.phi, impulses, limits, iterations,
                           converged, contacts.joints, generalized, contacts.local)  # fmt: skip
        return v_new, out

    def _rows(self, q, dt: float, data: pin.Data):
        """(contacts, J, gap, number of range rows): the rows of the ground's contacts (three
        each) and of the ranges near their limits, and each row's constant velocity term (a
        normal row's gap phi / dt, closed within the step, a penetration's the correction's
        fraction of it; the same for a range's distance); J None if there are no rows."""
        rows, gaps, contacts, n_limits = [], [], _NO_CONTACTS, 0
        corr = self.settings.correction
        if self.ground is not None:
            contacts = self.ground.detect(self.model, data, at=q)
            if len(contacts):
                rows.append(self.ground.jacobian(data, contacts))
                gap = np.zeros(3 * len(contacts))
                gap[2::3] = np.where(contacts.phi >= 0.0, contacts.phi, corr * contacts.phi) / dt
                gaps.append(gap)
        if self.ranges is not None:
            r, Jr = self.ranges.rows(q)
            n_limits = len(r)
            if n_limits:
                rows.append(Jr)
                gaps.append(np.where(r >= 0.0, r, corr * r) / dt)
        if not rows:
            return contacts, None, None, 0
        if len(rows) == 1:
            return contacts, rows[0], gaps[0], n_limits
        return contacts, np.vstack(rows), np.concatenate(gaps), n_limits

    def _pinocchio_solve(self, J, gap, Minv, v_free, n_ground: int, n_limits: int):
        """(impulses, v+, iterations, converged) by Pinocchio's solver (ADMM or PGS)."""
        g = J @ v_free + gap
        MJt = Minv @ J.T
        G = J @ MJt
        # Jacobi scaling: a hand's range row and a foot's contact differ by 1e6 in G; each
        # contact's three rows share one factor, so its friction cone is unchanged
        d = np.diag(G).copy()
        if n_ground:
            d[: 3 * n_ground] = np.repeat(d[: 3 * n_ground].reshape(-1, 3).mean(axis=1), 3)
        d = 1.0 / np.sqrt(np.maximum(d, 1e-12 * d.max()))
        cms, cds = self.ground.cones(n_ground) if n_ground and self.ground else ([], [])
        if n_limits:
            cm, cd = self._orthant(n_limits)
            cms, cds = [*cms, cm], [*cds, cd]
        res = self.result
        res.clearConstraintImpulseGuess()
        delassus = pin.DelassusOperatorDense(d[:, None] * G * d[None, :])
        self.solver.solve(delassus, d * g, cms, cds, self.solve_settings, res)
        lam = d * np.array(res.retrieveConstraintImpulses())
        return lam, v_free + MJt @ lam, int(res.iterations), bool(res.converged)

    def _kernel_solve(self, J, gap, Minv, v_free, contacts: GroundContacts):
        """(impulses, v+, iterations, converged) by the compiled ADMM (humanoid/kernels.c),
        started from the impulses the same points and range rows had at the last step; where
        it does not reach the tolerance within :data:`KERNEL_ITERATIONS` (an impact on many
        new contacts: its fixed penalty converges slowly there), Pinocchio's ADMM solves the
        step from zero (``fallbacks`` counts them)."""
        assert KERNELS is not None
        n, ranges = len(contacts), self.ranges
        lam = self._warm.start(contacts.ids, n, ranges.ids if ranges else None, len(gap))
        v_new = np.empty_like(v_free)
        st = self.settings
        J, Minv, v_free = (np.ascontiguousarray(a) for a in (J, Minv, v_free))
        iterations, converged, *_ = KERNELS.contact_solve(
            J, Minv, v_free, gap, n, st.mu, st.tolerance, KERNEL_RHO, KERNEL_ITERATIONS,
            KERNEL_ANDERSON, KERNEL_SCREEN, lam, v_new)  # fmt: skip
        if not converged:
            self.fallbacks += 1
            n_limits = len(gap) - 3 * n
            lam, v_new, more, converged = self._pinocchio_solve(J, gap, Minv, v_free, n, n_limits)
            iterations += more
        self._warm.keep(lam, n)
        return lam, v_new, iterations, bool(converged)
