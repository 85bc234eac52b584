"""Ground contact for every body: rigid, unilateral, with Coulomb friction, on the floor z = 0.

Built on what Pinocchio 4.1 and coal ship (the design of Inria's Simple simulator):

- **Detection.** The body's collision geometries (our primitives; meshes as their convex hulls)
  are paired with a ``coal.Halfspace`` floor; ``pin.computeCollisions`` with a security margin
  finds the geometries near it. Their contact points are the points of the shape that can be
  lowest: the vertices of a box or a convex hull, the lowest point of a sphere, of each end of a
  capsule and of each rim of a cylinder, and samples around the rims (a cylinder standing on its
  end). Those within the margin of the floor become contacts. (coal's contact patches project
  their points onto one plane, so a tilted box would rest on its projected corners.) A point
  that a body and its parent share (the rearfoot's front corners and the toes' rear ones, at
  an MTP angle near zero) is the child's alone while the two are within a millimetre.
- **Constraints.** Each contact is a ``pin.PointContactConstraintModel`` between the floor
  (joint 0, at the point's projection on z = 0, axes world-aligned: tangent x, y, normal z) and
  the body (at the point, on the geometry's joint), with a ``CoulombFrictionCone`` of friction
  coefficient mu. Models are pooled and moved in place.
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

from dataclasses import dataclass, field

import coal
import numpy as np
import pinocchio as pin

from ..errors import ModelError

__all__ = ["ContactSolver", "Ground", "GroundSettings"]

# ADMM tolerances: contact impulses of a 1 ms step are O(1e-3 .. 1) N s, so Pinocchio's 1e-6
# default would be loose.
TOLERANCE = 1e-9


@dataclass(frozen=True)
class GroundSettings:
    """Contact parameters.

    Attributes:
        mu: Coulomb friction coefficient.
        margin: [m] points closer than this to the floor are contact candidates.
        correction: Fraction of a penetration removed per step (0..1).
        tolerance: ADMM feasibility and complementarity tolerances.
        max_iterations: ADMM iteration cap per solve.
    """

    mu: float = 0.8
    margin: float = 0.01
    correction: float = 0.2
    tolerance: float = TOLERANCE
    max_iterations: int = 1000


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

    def placed(self, oMi: pin.SE3, rows=slice(None)) -> np.ndarray:
        """World positions of (some of) the fixed points, the joint at ``oMi``."""
        return self.fixed[rows] @ oMi.rotation.T + oMi.translation

    def lowest(self, oMi: pin.SE3) -> np.ndarray:
        """World points of the shape that can be lowest, (n, 3)."""
        R, t = oMi.rotation, oMi.translation
        pts = [self.placed(oMi)] if len(self.fixed) else []
        down = np.array([0.0, 0.0, -1.0])
        for c, r in self.spheres:
            pts.append((R @ c + t + r * down)[None])
        for c, a, r in self.rims:
            axis = R @ a
            d = down - (down @ axis) * axis  # the rim's lowest direction
            norm = np.linalg.norm(d)
            if norm > 1e-9:
                pts.append((R @ c + t + r * d / norm)[None])
        return np.vstack(pts)


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


class Ground:
    """The floor and the geometries that may touch it.

    Args:
        model: The Pinocchio model.
        geometry_model: Collision geometry (visual geometry for models that have none).
        geometries: Indices of the geometries that may touch the floor.
        settings: :class:`GroundSettings`.
    """

    def __init__(self, model: pin.Model, geometry_model: pin.GeometryModel, geometries,
                 settings: GroundSettings = GroundSettings()) -> None:  # fmt: skip
        self.settings = settings
        gm = pin.GeometryModel()
        floor = coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)
        self.floor = gm.addGeometryObject(pin.GeometryObject("floor", 0, pin.SE3.Identity(), floor))
        self.names, self.shapes = [], []
        for i in geometries:
            g = geometry_model.geometryObjects[i].copy()
            g.geometry = _convex(g.geometry)
            gid = gm.addGeometryObject(g)
            gm.addCollisionPair(pin.CollisionPair(self.floor, gid))
            self.names.append(g.name)
            self.shapes.append(_Shape(g))
        self.shared = _shared_corners(model, self.shapes)
        self.geometry_model = gm
        self.geometry_data = pin.GeometryData(gm)
        for req in self.geometry_data.collisionRequests:
            req.security_margin = settings.margin
        self._pool: list[tuple[pin.ConstraintModel, pin.ConstraintData]] = []
        self._model = model
        self._last: tuple | None = None  # ((model, configuration), contacts) of the last call

    def _contact(self, k: int):
        """The k-th pooled contact model (created on first use)."""
        while len(self._pool) <= k:
            pc = pin.PointContactConstraintModel(
                self._model, 0, pin.SE3.Identity(), 0, pin.SE3.Identity()
            )
            pc.setFriction(self.settings.mu)
            cm = pin.ConstraintModel(pc)
            self._pool.append((cm, cm.createData()))
        return self._pool[k]

    def detect(self, model: pin.Model, data: pin.Data, at=None):
        """Contacts of the current placements (``data.oMi`` must be up to date).

        ``at``: the configuration the placements are at. Given, a call at the same model and
        configuration as the last one returns its contacts again without detecting them: a
        controller and its plant detect at the same state every tick (a person's walk spent
        0.37 ms a tick in each).

        Returns:
            (models, datas, phi, points): the active contact constraints, their signed distances
            [m] (negative below the floor) and their world points on the body, (n, 3).
        """
        key = None if at is None else (model, np.asarray(at, dtype=float).tobytes())
        last = self._last
        if key is not None and last is not None and last[0][0] is model and last[0][1] == key[1]:
            cms, cds, phi, points = last[1]
            return list(cms), list(cds), phi.copy(), points.copy()
        found = self._detect(model, data)
        self._last = None if key is None else (key, found)
        cms, cds, phi, points = found
        return list(cms), list(cds), phi.copy(), points.copy()

    def _detect(self, model: pin.Model, data: pin.Data):
        """:meth:`detect`'s contacts, found."""
        gm, gd = self.geometry_model, self.geometry_data
        pin.updateGeometryPlacements(model, data, gm, gd)
        pin.computeCollisions(gm, gd, False)
        cms: list = []  # Pinocchio's contact models and datas
        cds: list = []
        points: list[np.ndarray] = []
        margin = self.settings.margin
        placements: dict[int, pin.SE3] = {}  # the joints' placements, read once
        hidden = self._hidden(data, placements)
        for pair, shape in enumerate(self.shapes):
            if not gd.collisionResults[pair].isCollision():
                continue
            oMi = _placement(data, shape.joint, placements)
            pts = shape.lowest(oMi)
            keep = pts[:, 2] < margin
            if pair in hidden:
                keep[hidden[pair]] = False
            pts = pts[keep]
            pts = pts[_extremes(pts, MAX_POINTS)] if len(pts) > MAX_POINTS else pts
            for p in pts:
                cm, cd = self._contact(len(cms))
                c = cm.extract()
                c.joint2_id = shape.joint
                c.joint1_placement.translation = np.array([p[0], p[1], 0.0])
                c.joint2_placement.translation = oMi.actInv(p)
                cms.append(cm)
                cds.append(cd)
                points.append(p)
        found = np.array(points).reshape(-1, 3)
        return cms, cds, found[:, 2].copy(), found

    def _hidden(self, data: pin.Data, placements: dict | None = None) -> dict:
        """{shape: indices of its points left out}: a parent's point within :data:`SHARED` of
        its child's now. There the two are one point of the body (at an MTP angle of zero the
        rearfoot's front corners are the toes' rear ones): as two contacts they are a
        degenerate pair that the solver splits between the bodies as its iterations happen to
        go (the stop's foot carried 260 N on the rearfoot's pair where the controller had
        planned it on the toes', and flicked the light toes up 0.4 rad). Apart (the joint bent
        3.4 degrees) both are contacts: left out for good, the rearfoot's front sank 9 mm into
        the floor under toes bent up."""
        out: dict[int, list[int]] = {}
        for a, b, ia, ib in self.shared:
            pa, pb = self.shapes[a], self.shapes[b]
            placements = {} if placements is None else placements
            wa = pa.placed(_placement(data, pa.joint, placements), ia)
            wb = pb.placed(_placement(data, pb.joint, placements), ib)
            near = ia[np.linalg.norm(wa - wb, axis=1) < SHARED]
            if len(near):
                out.setdefault(a, []).extend(near.tolist())
        return out


def _placement(data: pin.Data, joint: int, placements: dict) -> pin.SE3:
    """``data.oMi[joint]``, kept in ``placements`` (each read copies it)."""
    M = placements.get(joint)
    if M is None:
        M = placements[joint] = data.oMi[joint]
    return M


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
    """

    points: np.ndarray
    phi: np.ndarray
    impulses: np.ndarray
    limit_impulses: np.ndarray
    iterations: int
    converged: bool
    joints: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    limit_generalized: np.ndarray | None = None

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
                               np.cross(floor, self.impulses).sum(axis=0)])  # fmt: skip


class ContactSolver:
    """One velocity-level step of the ground contacts and unilateral rows (joint ranges)."""

    def __init__(self, model: pin.Model, ground: Ground | None, ranges=None,
                 settings: GroundSettings = GroundSettings()) -> None:  # fmt: skip
        self.model, self.ground, self.ranges, self.settings = model, ground, ranges, settings
        self.solver = pin.ADMMConstraintSolver()
        st = pin.ADMMSolverSettings()
        st.absolute_feasibility_tol = st.relative_feasibility_tol = settings.tolerance
        st.absolute_complementarity_tol = st.relative_complementarity_tol = settings.tolerance
        st.max_iterations = settings.max_iterations
        st.admm_update_rule = pin.ADMMUpdateRule.SPECTRAL  # no iteration-cap hits on impacts
        self.admm = st
        self.result = pin.ADMMSolverResult()
        self._orthants: dict[int, tuple] = {}
        self.failures = 0

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
        model = self.model
        cms, cds, rows = [], [], []
        g_parts = []
        phi = points = np.zeros((0,))
        n_ground = 0
        if self.ground is not None:
            cms, cds, phi, points = self.ground.detect(model, data, at=q)
            n_ground = len(cms)
            if n_ground:
                for cm, cd in zip(cms, cds, strict=True):
                    cm.calc(model, data, cd)
                Jg = pin.getConstraintsJacobian(model, data, cms, cds)
                gap = np.where(phi >= 0.0, phi, self.settings.correction * phi) / dt
                gg = Jg @ v_free
                gg[2::3] += gap
                rows.append(Jg)
                g_parts.append(gg)
        n_limits = 0
        if self.ranges is not None:
            r, Jr = self.ranges.rows(q)
            n_limits = len(r)
            if n_limits:
                gap = np.where(r >= 0.0, r, self.settings.correction * r) / dt
                rows.append(Jr)
                g_parts.append(Jr @ v_free + gap)
                cm, cd = self._orthant(n_limits)
                cms, cds = [*cms, cm], [*cds, cd]
        if not rows:
            none = np.zeros((0, 3))
            return v_free, StepContacts(none, np.zeros(0), none, np.zeros(0), 0, True,
                                        limit_generalized=np.zeros(model.nv))  # fmt: skip
        J = np.vstack(rows)
        g = np.concatenate(g_parts)
        MJt = Minv @ J.T
        G = J @ MJt
        # Jacobi scaling: a hand's range row and a foot's contact differ by 1e6 in G; each
        # contact's three rows share one factor, so its friction cone is unchanged
        d = np.diag(G).copy()
        if n_ground:
            d[: 3 * n_ground] = np.repeat(d[: 3 * n_ground].reshape(-1, 3).mean(axis=1), 3)
        d = 1.0 / np.sqrt(np.maximum(d, 1e-12 * d.max()))
        res = self.result
        res.clearConstraintImpulseGuess()
        delassus = pin.DelassusOperatorDense(d[:, None] * G * d[None, :])
        self.solver.solve(delassus, d * g, cms, cds, self.admm, res)
        lam = d * np.array(res.retrieveConstraintImpulses())
        if not res.converged:
            self.failures += 1
        v_new = v_free + MJt @ lam
        impulses = lam[: 3 * n_ground].reshape(-1, 3)
        joints = np.array([cm.extract().joint2_id for cm in cms[:n_ground]], dtype=int)
        limits = lam[3 * n_ground :]
        generalized = J[3 * n_ground :].T @ limits if n_limits else np.zeros(model.nv)
        out = StepContacts(points, phi, impulses, limits, int(res.iterations),
                           bool(res.converged), joints, generalized)  # fmt: skip
        return v_new, out
