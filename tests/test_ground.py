"""Ground contact for every body and joint ranges as constraints: analytic friction results,
a body dropped onto the floor, and the range rows against finite differences."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest
from conftest import BODIES, SCENES, get_model

import humanoid as hm
from humanoid.constraints.ground import ContactSolver, Ground, GroundSettings
from humanoid.constraints.limits import JointRanges
from humanoid.errors import SceneError
from humanoid.scene import Effects, GroundSpec, Scene

G0 = 9.81
BOX = (0.2, 0.1, 0.05)  # [m]


def _box(mu: float, slope_deg: float = 0.0, solver: str = "admm"):
    """A 1 kg box on the floor; a slope is the gravity turned by its angle."""
    model = pin.Model()
    jid = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "box")
    model.appendBodyToJoint(jid, pin.Inertia.FromBox(1.0, *BOX), pin.SE3.Identity())
    th = np.radians(slope_deg)
    model.gravity.linear = np.array([-G0 * np.sin(th), 0.0, -G0 * np.cos(th)])
    gm = pin.GeometryModel()
    gm.addGeometryObject(pin.GeometryObject("box", jid, pin.SE3.Identity(), coal.Box(*BOX)))
    settings = GroundSettings(mu=mu, solver=solver)
    return model, ContactSolver(model, Ground(model, gm, [0], settings), None, settings)


def _run(model, solver, q, v, T, dt):
    """Semi-implicit Euler with the contact impulses; the states after every step."""
    data = model.createData()
    states = []
    for _ in range(int(round(T / dt))):
        v_free = v + dt * pin.aba(model, data, q, v, np.zeros(model.nv))
        pin.computeJointJacobians(model, data, q)
        Minv = pin.computeMinverse(model, data, q)
        v, found = solver.step(q, v_free, dt, np.triu(Minv) + np.triu(Minv, 1).T, data)
        q = pin.integrate(model, q, dt * v)
        states.append((q.copy(), v.copy(), found))
    return states


@pytest.mark.parametrize("kind", ["admm", "kernel"])
def test_a_sliding_box_stops_at_the_analytic_distance(kind):
    """v0 = 2 m/s, mu = 0.5: it stops after v0^2 / (2 mu g) = 0.4077 m, to 1e-3 relative at
    dt = 0.25 ms (the scheme's bias is v0 dt / 2), then sticks; Pinocchio's ADMM and the
    compiled one (warm-started) alike."""
    model, solver = _box(0.5, solver=kind)
    q = pin.neutral(model)
    q[2] = BOX[2] / 2
    v = np.zeros(6)
    v[0] = 2.0
    states = _run(model, solver, q, v, 0.6, 2.5e-4)
    distance = states[-1][0][0]
    expected = 2.0**2 / (2 * 0.5 * G0)
    assert abs(distance - expected) < 1e-3 * expected
    assert abs(states[-1][1][0]) < 1e-8  # at rest, sticking
    assert abs(states[-1][0][2] - BOX[2] / 2) < 1e-6  # on the floor, not in it
    assert solver.failures == 0


def test_pgs_solves_the_same_problems():
    """Pinocchio's projected Gauss-Seidel (``GroundSettings(solver="pgs")``) on the box that
    slides, stops and sticks: the same path as ADMM's to 1e-4 m (3e-5 measured: the four
    corners share the load differently), stopped on the floor; but where ADMM sticks and
    converges at every step, PGS creeps on at 1e-5 m/s and stops at its iteration cap short
    of the tolerance. A scene names a solver it does not have."""
    model, admm = _box(0.5)
    settings = GroundSettings(mu=0.5, solver="pgs")
    pgs = ContactSolver(model, admm.ground, None, settings)
    assert isinstance(pgs.solver, pin.PGSConstraintSolver)
    q = pin.neutral(model)
    q[2] = BOX[2] / 2
    v = np.zeros(6)
    v[0] = 2.0
    a = _run(model, admm, q, v, 0.5, 1e-3)
    b = _run(model, pgs, q, v, 0.5, 1e-3)
    assert max(np.abs(x[0] - y[0]).max() for x, y in zip(a, b, strict=True)) < 1e-4
    # stopped: ADMM sticks to 1e-8 m/s, PGS creeps on (1.1e-5 m/s measured)
    assert abs(a[-1][1][0]) < 1e-8 and 1e-8 < abs(b[-1][1][0]) < 1e-4
    assert abs(b[-1][0][2] - BOX[2] / 2) < 1e-6
    assert admm.failures == 0 < pgs.failures  # PGS stops at its 1000 iterations (93 of 500)
    with pytest.raises(
        SceneError, match="unknown contact solver 'lemke': must be kernel, admm or pgs"
    ):
        ContactSolver(model, admm.ground, None, GroundSettings(solver="lemke"))
    with pytest.raises(SceneError, match="effects.ground.solver.*unknown contact solver 'lemke'"):
        Scene(body=str(BODIES / "adult_male.urdf"), integrator="semi_implicit_euler",
              effects=Effects(ground=GroundSpec(solver="lemke")))  # fmt: skip


@pytest.mark.parametrize("kind", ["admm", "kernel"])
@pytest.mark.parametrize(("slope", "mu"), [(20.0, 0.5), (25.0, 0.5), (28.0, 0.5), (35.0, 0.5)])
def test_a_box_on_a_slope_sticks_below_atan_mu_and_slides_above(slope, mu, kind):
    """atan(0.5) = 26.57 deg: below it the box stays (< 1e-8 m in 1 s), above it slides with
    g (sin - mu cos) to 1e-3 relative (either ADMM)."""
    model, solver = _box(mu, slope, solver=kind)
    q = pin.neutral(model)
    q[2] = BOX[2] / 2
    states = _run(model, solver, q, np.zeros(6), 1.0, 1e-3)
    x = np.array([s[0][0] for s in states])
    t = 1e-3 * np.arange(1, len(x) + 1)
    th = np.radians(slope)
    if np.tan(th) < mu:
        assert np.abs(x).max() < 1e-8
    else:
        a = -2 * np.polyfit(t, x, 2)[0]  # down the slope is -x
        expected = G0 * (np.sin(th) - mu * np.cos(th))
        assert abs(a - expected) < 1e-3 * expected


@pytest.fixture(scope="module", params=["drop", "collapse"])
def fall(request):
    """The shipped drop (from 0.5 m) and collapse (from standing) scenes, recorded at every
    step."""
    scene = Scene.load(SCENES / f"{request.param}.toml").replace(record_rate=1000.0)
    return scene, hm.simulate(scene, quiet=True)


def test_a_falling_body_comes_to_rest_on_the_floor(fall):
    """Dropped from 0.5 m it lands and falls over; standing passive, it collapses. Either
    way: no contact point is ever more than 1 mm below the floor, the energy never rises
    (1e-6 J per step: the contact solver's tolerance), it ends at rest, lying down, its weight
    on the floor."""
    scene, traj = fall
    assert traj.status == "completed"
    meta = traj.metadata
    assert meta["max_penetration"] < 1e-3
    # of 4000-6000 steps (ADMM at its 1000-iteration cap); and those the compiled solver
    # handed to Pinocchio's ADMM (14 and 15 measured)
    assert meta["contact_solver_failures"] <= 4
    assert 0 < meta["contact_solver_fallbacks"] < 0.05 * meta["steps"]
    assert np.diff(traj.energy).max() < 1e-6
    assert traj.energy[-1] < traj.energy[0] - 0.5 * 75.0 * G0  # the CoM fell by over 0.5 m
    h = hm.load(BODIES / "adult_male.urdf")
    ke = 0.5 * traj.v[-1] @ hm.mass_matrix(h, traj.q[-1]) @ traj.v[-1]
    assert ke < 1e-4
    assert traj.q[-1, 2] < 0.3  # the pelvis is down: it fell over
    assert np.abs(traj.forces["ground"][-1, 2] - h.mass * G0) < 1e-3 * h.mass * G0


def test_joint_ranges_hold_in_the_fall(fall):
    """Every joint, hinge and ball (its triplet angles), stays in its range to 1 degree."""
    scene, traj = fall
    h = hm.load(BODIES / "adult_male.urdf")
    ranges = JointRanges(h)
    worst = max(ranges.violation(q) for q in traj.q)
    assert np.degrees(worst) < 1.0


@pytest.mark.parametrize("name", ["male", "human"])
def test_range_rows_match_finite_differences(name):
    """r(q (+) eps w) - r(q) = eps J w to O(eps^2), on states inside the ranges, every row."""
    h = get_model(name, "quaternion")
    ranges = JointRanges(h)
    rng = np.random.default_rng(71)
    q = h.standing_configuration()
    q[ranges.iq] = ranges.lo + (ranges.hi - ranges.lo) * rng.uniform(0.3, 0.7, len(ranges.iq))
    for ball, iq, _, lo, hi in ranges.balls:  # each ball inside its range, off the middle
        q[iq : iq + 4] = pin.Quaternion(ball.rotation(lo + (hi - lo) * rng.uniform(0.3, 0.7, 3)))\
            .coeffs()  # fmt: skip
    r, J = ranges.rows(q, margin=None)
    assert len(r) == 2 * (len(ranges.iq) + 3 * len(ranges.balls))
    assert r.min() > 0  # inside every range
    eps = 1e-6
    w = rng.normal(size=h.nv)
    r2, _ = ranges.rows(pin.integrate(h.model, q, eps * w), margin=None)
    np.testing.assert_allclose((r2 - r) / eps, J @ w, atol=1e-4)
    # excess: zero inside every range; a hinge pushed 0.1 rad past its upper bound shows 0.1
    # there and nowhere else
    assert np.abs(ranges.excess(q)).max() == 0.0
    q_out = q.copy()
    q_out[ranges.iq[0]] = ranges.hi[0] + 0.1
    x = ranges.excess(q_out)
    assert abs(x.max() - 0.1) < 1e-12 and np.count_nonzero(x) == 1


def test_ground_scene_errors_name_the_key():
    male = str(BODIES / "adult_male.urdf")
    with pytest.raises(SceneError, match="integrator.*semi_implicit_euler"):
        Scene(body=male, integrator="rk4", effects=Effects(ground=GroundSpec()))
    with pytest.raises(SceneError, match="effects.ground.mu"):
        Scene(
            body=male, integrator="semi_implicit_euler", effects=Effects(ground=GroundSpec(mu=-1))
        )
    scene = Scene(body=male, integrator="semi_implicit_euler",
                  effects=Effects(ground=GroundSpec(bodies=("tail",))))  # fmt: skip
    with pytest.raises(SceneError, match="no link 'tail'; links: .*pelvis"):
        hm.simulate(scene, quiet=True)


def test_standing_on_the_ground_contact_holds_for_ten_seconds():
    """balance.toml: no welds, the feet held by friction on unilateral point contacts, the
    posture hold on. For 10 s the soles move less than 0.1 mm, the body stays up and the
    floor carries its weight."""
    scene = Scene.load(SCENES / "balance.toml")
    assert scene.duration == 10.0
    traj = hm.simulate(scene, quiet=True)
    assert traj.status == "completed"
    h = hm.load(BODIES / "adult_male.urdf")
    data = h.model.createData()
    soles = [h.frame_id(f) for f in h.feet]

    def placements(q):
        pin.framesForwardKinematics(h.model, data, q)
        return [data.oMf[f].copy() for f in soles]

    start = placements(traj.q[0])
    drift = 0.0
    for q in traj.q:
        for m0, m in zip(start, placements(q), strict=True):
            drift = max(drift, np.linalg.norm(m.translation - m0.translation))
            drift = max(drift, 0.1 * np.linalg.norm(pin.log3(m0.rotation.T @ m.rotation)))
    assert drift < 1e-4  # [m]; a rotation counts at a 0.1 m lever arm
    assert abs(traj.q[-1, 2] - traj.q[0, 2]) < 1e-3
    assert np.abs(traj.forces["ground"][-100:, 2] - h.mass * G0).max() < 1e-3 * h.mass * G0
    assert traj.metadata["contact_solver_failures"] == 0


def test_a_body_sliding_on_ice_feels_kinetic_friction_until_it_stops():
    """slide.toml: tossed forward at 2 m/s onto a floor with mu = 0.1, it falls and slides on
    its back. While it slides, its weight on the floor, the floor's horizontal force is mu times
    its normal force (1e-6 relative: the cone's edge, not a pyramid's), against the CoM's
    motion; then it sticks, at rest, its weight on the floor, the horizontal force zero. (Not
    in an impact: a heel striking the floor at 14 body weights may stick while the back
    slides, and the total is then inside the cone.)"""
    scene = Scene.load(SCENES / "slide.toml")
    traj = hm.simulate(scene, quiet=True)
    assert traj.status == "completed"
    h = hm.load(BODIES / "adult_male.urdf")
    model, data = h.model, h.model.createData()
    mu = scene.effects.ground.mu
    f = traj.forces["ground"]
    sliding = 0
    for k, (q, v) in enumerate(zip(traj.q, traj.v, strict=True)):
        pin.centerOfMass(model, data, q, v)
        vc = data.vcom[0][:2]
        if q[2] < 0.2 and np.linalg.norm(vc) > 0.05 and 0.9 < f[k, 2] / (h.mass * G0) < 1.5:
            sliding += 1
            ft = f[k, :2]
            assert abs(np.linalg.norm(ft) - mu * f[k, 2]) < 1e-6 * f[k, 2]
            assert ft @ vc < -0.99 * np.linalg.norm(ft) * np.linalg.norm(vc)
    assert sliding > 50  # records (100 Hz): over half a second of sliding on its back
    weight = h.mass * G0
    assert np.abs(f[-1, :2]).max() < 1e-6 * weight and abs(f[-1, 2] - weight) < 1e-3 * weight
    assert 0.5 * traj.v[-1] @ hm.mass_matrix(h, traj.q[-1]) @ traj.v[-1] < 1e-4


@pytest.mark.parametrize("name", ["drop", "slide"])
def test_ground_impulses_change_momentum_by_exactly_their_sum(name):
    """Step by step through the first 1.2 s of a fall (impacts, sticking, sliding): the ground
    and range impulses change the linear momentum by the sum of the ground impulses and the
    angular momentum about the CoM by the sum of their moments at the body's contact points
    (1e-9 relative); joint-range impulses add nothing (they are internal)."""
    from humanoid.simulation import Simulation

    scene = Scene.load(SCENES / f"{name}.toml")
    sim = Simulation(scene)
    model, data = sim.h.model, sim.h.model.createData()
    q, v, dt = sim.q0, sim.v0, scene.dt
    touching = 0
    for k in range(1200):
        v_free = v + dt * sim.plant.acceleration(k * dt, q, v)
        q_new, v_new = sim.plant.ground.advance(k * dt, q, v, dt)
        found = sim.ground_step
        A = pin.computeCentroidalMap(model, data, q)
        c = data.com[0].copy()
        dh = A @ (v_new - v_free)
        lam = found.impulses
        expected = np.concatenate([lam.sum(axis=0), np.cross(found.points - c, lam).sum(axis=0)])
        scale = max(np.abs(expected).max(), 1.0)
        assert np.abs(dh - expected).max() < 1e-9 * scale, (k, dh, expected)
        touching += len(lam) > 0
        q, v = q_new, v_new
    assert touching > 500


@pytest.mark.parametrize(("name", "energy_rise"), [("human", 1e-6), ("talos", 0.5)])
def test_example_robot_data_bodies_land_on_their_meshes(name, energy_rise):
    """example-robot-data's human and Talos touch the floor with their meshes' convex hulls
    (support points). Dropped 0.1 m, they land and fold: no point more than 1 mm below the
    floor (measured 0.06 mm and 0.8 mm), the floor's impulse positive. The human's energy never
    rises; Talos's rises once, by 0.12 J, when the solver pushes its 0.8 mm out (a gap still
    open: the bound here is 0.5 J)."""
    from humanoid.scene import Initial, JointLimitSpec

    h = get_model(name, "quaternion")
    scene = Scene(body=h.source, duration=0.8, dt=1e-3, integrator="semi_implicit_euler",
                  record_rate=1000.0, initial=Initial(lift=0.1),
                  effects=Effects(damping=0.5, joint_limits=JointLimitSpec("constraint"),
                                  ground=GroundSpec(tolerance=1e-7)))  # fmt: skip
    traj = hm.simulate(scene, humanoid=h, quiet=True)
    assert traj.status == "completed"
    assert traj.metadata["max_penetration"] < 1e-3
    assert np.diff(traj.energy).max() < energy_rise
    assert traj.forces["ground"][:, 2].sum() * 1e-3 > 0.5 * h.mass * G0 * 0.6  # [N s]


@pytest.mark.parametrize("margin", [0.0, 0.1])
def test_range_certificates_skip_only_what_is_clear(margin):
    """A random walk of the whole body about standing (mean-reverting), in and out of its
    ranges: the rows with the certificates (the decomposition skipped when no ball can be near
    a limit) equal those decomposed at every step, and the certificates do skip steps."""
    h = get_model("male", "quaternion")
    lazy, exact = JointRanges(h, compiled=False), JointRanges(h, compiled=False)
    rng = np.random.default_rng(72)
    q0 = q = h.standing_configuration()
    skipped = 0
    for _ in range(600):
        w = rng.normal(scale=0.01, size=h.nv) - 0.02 * pin.difference(h.model, q0, q)
        w[:6] = 0.0
        q = pin.integrate(h.model, q, w)
        r1, J1 = lazy.rows(q, margin=margin)
        r2, J2 = exact.rows(q, margin=margin, certified=False)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(J1, J2)
        skipped += lazy.skipped
    assert 50 < skipped < 600


def test_a_posture_hold_on_the_floor_is_stepped_implicitly():
    """balance.toml pushed forward with 100 N at the thorax for 0.2 s: the feet rock onto their
    toes and back. The hold's ankle gains, tuned on the body standing on both feet, then meet a
    foot's own inertia, a mode far beyond what an explicit 1 ms step follows (taken explicitly
    it exploded 40 ms after the push began). Taken implicitly the body recovers: standing
    again, pelvis within 5 mm of its height, its pelvis rocking no faster than 0.3 m/s or
    rad/s over the last second (measured 0.17 rad/s of pitch; not at rest: the hold's ankle
    gains and the heel's and toes' contacts keep a limit cycle, the light toes flicking at up
    to 0.9 rad/s). And every step's velocity change is what
    the recorded joint torques, b(q, v) and the ground impulses give (outside the push):
    M (v+ - v) = dt (tau - b) + sum J_p^T lambda_p, to 1e-9 of the largest term."""
    import dataclasses

    from humanoid.scene import PushSpec
    from humanoid.simulation import Simulation

    scene = Scene.load(SCENES / "balance.toml")
    push = PushSpec("thorax", (100.0, 0.0, 0.0), 0.5, 0.2)
    scene = scene.replace(effects=dataclasses.replace(scene.effects, pushes=(push,)))
    sim = Simulation(scene)
    model, data = sim.h.model, sim.h.model.createData()
    q, v, dt = sim.q0, sim.v0, scene.dt
    checked, speed = 0, 0.0
    for k in range(2500):
        t = k * dt
        r = sim.step(t, q, v, dt)
        found = sim.ground_step
        if not 0.5 - dt <= t <= 0.7 + dt:
            M = pin.crba(model, data, q)
            b = pin.nle(model, data, q, v)
            pin.computeJointJacobians(model, data, q)
            impulse = np.zeros(model.nv)
            for p, lam, j in zip(found.points, found.impulses, found.joints, strict=True):
                J = pin.getJointJacobian(model, data, int(j), pin.LOCAL_WORLD_ALIGNED)
                arm = p - data.oMi[int(j)].translation
                impulse += (J[:3] - np.cross(arm, J[3:].T).T).T @ lam
            lhs, rhs = M @ (r.v - v), dt * (r.torque - b) + impulse
            scale = max(np.abs(lhs).max(), np.abs(dt * b).max(), np.abs(impulse).max())
            assert np.abs(lhs - rhs).max() < 1e-9 * scale, (t, np.abs(lhs - rhs).max(), scale)
            checked += 1
        q, v = r.q, r.v
        speed = max(speed, float(np.abs(v).max()))
        if t >= 1.5:
            assert abs(q[2] - sim.q0[2]) < 5e-3 and np.abs(v[:6]).max() < 0.3, (t, q[2], v[:6])
    assert checked > 2000 and sim.counters["implicit"] == 2500
    assert speed < 5.0  # [rad/s, m/s]: it rocked, nothing flew


def _feet_ground():
    """The male body and a ground of its feet's geometries alone (rearfoot and toes)."""
    h = hm.load(BODIES / "adult_male.urdf")
    model = h.model
    roots = [model.frames[h.frame_id(f)].parentJoint for f in h.feet]
    feet = {j for root in roots for j in model.subtrees[root]}
    geometry = h.collision_model
    chosen = [i for i, g in enumerate(geometry.geometryObjects) if g.parentJoint in feet]
    return h, Ground(model, geometry, chosen)


def test_a_foot_and_its_toes_share_no_ground_point():
    """At an MTP angle near zero the rearfoot's front corners and the toes' rear corners are one
    point: the ground keeps the toes' alone (a coincident pair is split arbitrarily by the
    solver). Standing flat, each foot touches at its heel's two corners, the metatarsal heads'
    two and the toe tip's two, no two of them closer than 1 mm, and the metatarsal heads' are
    on the toes. With the toes bent up 20 degrees the rearfoot's front corners are contacts
    again (left out, the rearfoot's front sank into the floor)."""
    h, ground = _feet_ground()
    model = h.model
    data = model.createData()
    q = h.standing_configuration()
    pin.framesForwardKinematics(model, data, q)
    q[2] -= min(data.oMf[h.frame_id(f"{s}_heel_inner")].translation[2] for s in ("left", "right"))

    def touching(q):
        pin.framesForwardKinematics(model, data, q)
        found = ground.detect(model, data)
        phi, points = found.phi, found.points
        return points[np.abs(phi) < 1e-6], points[phi < 0.01]

    down, _ = touching(q)
    assert len(down) == 12, down
    gaps = np.linalg.norm(down[:, None] - down[None], axis=2) + np.eye(len(down))
    assert gaps.min() > 1e-3
    for side in ("left", "right"):
        for edge in ("inner", "outer"):
            meta = data.oMf[h.frame_id(f"{side}_meta_{edge}")].translation
            assert np.linalg.norm(down - meta, axis=1).min() < 1e-9, (side, edge)
    # the rearfoot's front corners are where the metatarsal heads were at MTP zero
    front = [data.oMf[h.frame_id(f"right_meta_{e}")].translation.copy() for e in ("inner", "outer")]
    q[model.joints[model.getJointId("right_mtp")].idx_q] = np.radians(20.0)
    _, near = touching(q)
    for corner in front:
        assert np.linalg.norm(near - corner, axis=1).min() < 1e-9, corner


def test_a_detection_at_the_last_configuration_is_the_last_one_and_any_other_is_made_anew():
    """``Ground.detect(..., at=q)``: a second call at the same model and configuration (a
    controller's, then its plant's) returns the first's contacts; a call at another
    configuration, or without ``at``, detects them, and a call back at the first is detected
    again (only the last call is kept)."""
    (h, ground), (_, fresh) = _feet_ground(), _feet_ground()
    model = h.model
    data = model.createData()
    standing = h.standing_configuration()
    pin.framesForwardKinematics(model, data, standing)
    heels = [h.frame_id(f"{s}_heel_inner") for s in ("left", "right")]
    standing[2] -= min(data.oMf[f].translation[2] for f in heels)
    tilted = standing.copy()
    tilted[2] += 0.004  # 4 mm up: inside the margin, other distances
    for q in (standing, standing, tilted, standing, tilted, tilted):
        pin.framesForwardKinematics(model, data, q)
        found, found0 = ground.detect(model, data, at=q), fresh.detect(model, data)
        phi, points, phi0, points0 = found.phi, found.points, found0.phi, found0.points
        np.testing.assert_array_equal(phi, phi0)
        np.testing.assert_array_equal(points, points0)
    # the same configuration on a data not brought to it: the last contacts, as documented
    phi = ground.detect(model, model.createData(), at=tilted).phi
    np.testing.assert_array_equal(phi, phi0)


def _brute_points(g: pin.GeometryObject, M: pin.SE3) -> np.ndarray:
    """A geometry's candidate points placed at M, one by one from its coal shape: a box's
    corners, a sphere's bottom, a cylinder's rim samples and each rim's lowest point."""
    shape = g.geometry
    if isinstance(shape, coal.Box):
        h = np.asarray(shape.halfSide)
        return np.array([M.act(np.array([x, y, z]) * h)
                         for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])  # fmt: skip
    if isinstance(shape, coal.Sphere):
        return (M.translation - [0.0, 0.0, shape.radius])[None]
    assert isinstance(shape, coal.Cylinder), type(shape)
    R, out = M.rotation, []
    for s in (-1.0, 1.0):
        c = M.act(np.array([0.0, 0.0, s * shape.halfLength]))
        for a in np.linspace(0.0, 2 * np.pi, 8, endpoint=False):
            out.append(c + shape.radius * (np.cos(a) * R[:, 0] + np.sin(a) * R[:, 1]))
        d = np.array([0.0, 0.0, -1.0]) + R[2, 2] * R[:, 2]
        if np.linalg.norm(d) > 1e-9:
            out.append(c + shape.radius * d / np.linalg.norm(d))
    return np.array(out)


def _near_the_floor(h, rng):
    """A random posture of h (each joint turned by up to 0.8 rad from neutral, seeded), the
    pelvis turned at random, lowered until its lowest geometry is 1 mm into the floor; and the
    geometries' placements there."""
    model, geometry = h.model, h.collision_model
    q = pin.integrate(model, pin.neutral(model), rng.uniform(-0.8, 0.8, model.nv))
    q[:3] = 0.0
    q[3:7] = pin.Quaternion(pin.exp3(rng.uniform(-np.pi, np.pi, 3))).coeffs()
    gd = pin.GeometryData(geometry)
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateGeometryPlacements(model, data, geometry, gd)
    low = min(_brute_points(g, gd.oMg[i])[:, 2].min()
              for i, g in enumerate(geometry.geometryObjects))  # fmt: skip
    q[2] = -low - 1e-3
    pin.forwardKinematics(model, data, q)
    pin.computeJointJacobians(model, data, q)
    pin.updateGeometryPlacements(model, data, geometry, gd)
    return q, data, gd


def test_detection_finds_the_points_each_shape_places_one_by_one():
    """The ground places every geometry's candidate points at once: each detected point is a
    candidate of a geometry of its joint, placed by Pinocchio's own geometry placements
    (1e-12 m), with phi its height; and each geometry's lowest candidate within the margin is
    detected (or, on a rearfoot, its toes' point at the same place), in 20 random postures
    with the pelvis turned at random."""
    h = hm.load(BODIES / "adult_male.urdf")
    geometry = h.collision_model
    settings = GroundSettings(margin=0.05)
    ground = Ground(h.model, geometry, range(geometry.ngeoms), settings)
    rng = np.random.default_rng(3)
    found_any = 0
    for _ in range(20):
        q, data, gd = _near_the_floor(h, rng)
        found = ground.detect(h.model, data)
        brute = [(g.parentJoint, _brute_points(g, gd.oMg[i]))
                 for i, g in enumerate(geometry.geometryObjects)]  # fmt: skip
        np.testing.assert_array_equal(found.phi, found.points[:, 2])
        for p, j, local in zip(found.points, found.joints, found.local, strict=True):
            gap = min(np.linalg.norm(pts - p, axis=1).min() for jj, pts in brute if jj == j)
            assert gap < 1e-12, (h.model.names[j], p)
            np.testing.assert_allclose(data.oMi[int(j)].act(local), p, atol=1e-12)
        for _, pts in brute:
            lowest = pts[pts[:, 2].argmin()]
            if lowest[2] < settings.margin:
                assert np.linalg.norm(found.points - lowest, axis=1).min() < 1e-3, lowest
        found_any += len(found)
    assert found_any > 100


def test_the_contact_jacobian_is_pinocchios_point_contact_jacobian():
    """``Ground.jacobian`` (each point's velocity from its joint's world Jacobian, all points
    at once) against Pinocchio's PointContactConstraintModel for the same points (world axes,
    floor at joint 0): 1e-12, in random postures with the pelvis turned at random."""
    h = hm.load(BODIES / "adult_male.urdf")
    model, geometry = h.model, h.collision_model
    ground = Ground(model, geometry, range(geometry.ngeoms), GroundSettings(margin=0.05))
    rng = np.random.default_rng(4)
    points = 0
    for _ in range(5):
        q, data, _ = _near_the_floor(h, rng)
        found = ground.detect(model, data)
        assert len(found) >= 1
        points += len(found)
        cms, cds = [], []
        for j, local, p in zip(found.joints, found.local, found.points, strict=True):
            floor = pin.SE3(np.eye(3), np.array([p[0], p[1], 0.0]))
            cm = pin.ConstraintModel(pin.PointContactConstraintModel(
                model, 0, floor, int(j), pin.SE3(np.eye(3), local)))  # fmt: skip
            cd = cm.createData()
            cm.calc(model, data, cd)
            cms.append(cm)
            cds.append(cd)
        expected = pin.getConstraintsJacobian(model, data, cms, cds)
        np.testing.assert_allclose(ground.jacobian(data, found), expected, atol=1e-12)
    assert points >= 15, points


def test_diagonal_implicit_gains_are_an_armature():
    """The ground step's (M + dt D + dt^2 K)^-1: with diagonal gains (the drop's joint
    damping, a diagonal stiffness added) Pinocchio's inverse of the model with them as its
    armature, equal to the Cholesky inverse of the sum to 1e-10 relative; with a gain off
    the diagonal, the Cholesky inverse itself."""
    from humanoid.simulation import Simulation

    sim = Simulation(Scene.load(SCENES / "drop.toml").replace(duration=0.01))
    step = sim.plant.ground
    K0, D = step.implicit_terms()
    model, data = sim.plant.model, sim.plant.data
    rng = np.random.default_rng(8)
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    q[3:7] = pin.Quaternion(pin.exp3(rng.normal(size=3))).coeffs()
    dt = 1e-3
    for K in (K0 + np.diag(rng.uniform(0, 500, model.nv)), K0 + 50.0):
        want = np.linalg.inv(pin.crba(model, data, q) + dt * D + dt * dt * K)
        got = step._implicit_inverse(0.0, q, dt, K, D)
        assert (step._armed[3] is not None) == (np.count_nonzero(K - np.diag(np.diag(K))) == 0)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-10 * np.abs(want).max())


@pytest.mark.parametrize(("name", "dt"), [("drop", 1e-2), ("slide", 4e-3)])
def test_a_long_step_finds_a_fast_body_before_it_reaches_the_floor(name, dt):
    """At a long step the ground's candidates reach SPECULATIVE_SPEED times it from the floor
    (5 m/s: 5 cm at 10 ms): the drop's body, landing at 3.1 m/s, and the slide's, tossed at
    2 m/s and tumbling, stay within 1 mm of the floor (with the 1 cm margin alone, 18 mm
    and 13.5 mm deep: a whole step's fall before their contacts were found). At the default
    1 ms step the margin is the scene's own."""
    from humanoid.constraints.ground import SPECULATIVE_SPEED
    from humanoid.simulation import Simulation

    scene = Scene.load(SCENES / f"{name}.toml").replace(dt=dt, duration=0.6, record_rate=100.0)
    sim = Simulation(scene)
    assert sim.ground.settings.margin == pytest.approx(SPECULATIVE_SPEED * dt)
    traj = sim.run(quiet=True)
    assert traj.status == "completed"
    assert traj.metadata["max_penetration"] < 1e-3
    default = Simulation(Scene.load(SCENES / f"{name}.toml"))
    assert default.ground.settings.margin == scene.effects.ground.margin == 0.01
