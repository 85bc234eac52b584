"""The constraint layer: cross-checks with pin.constraintDynamics, hard sets, Jacobians, seeds."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model, random_state

from humanoid.constraints import (
    Baumgarte,
    PointContact,
    Weld,
    constrained_dynamics,
    solve_kkt,
    update_kinematics,
)
from humanoid.constraints.quaternion import CoordinateMap, QuaternionNorm
from humanoid.integrators import CoordinateSpace, rk4


def _welds(h, q, data=None):
    m = h.model
    data = data or m.createData()
    pin.framesForwardKinematics(m, data, q)
    return [Weld(f, m.getFrameId(f), data.oMf[m.getFrameId(f)]) for f in h.feet]


def _points(h, q):
    m = h.model
    data = m.createData()
    pin.framesForwardKinematics(m, data, q)
    names = h.contact_points["left"] + h.contact_points["right"]
    return [PointContact(n, m.getFrameId(n), data.oMf[m.getFrameId(n)].translation) for n in names]


def _pinocchio(h, q, v, tau, constraints):
    m = h.model
    cms = pin.StdVec_RigidConstraintModel()
    for c in constraints:
        fr = m.frames[c.frame_id]
        cms.append(
            pin.RigidConstraintModel(
                pin.ContactType.CONTACT_6D, m, fr.parentJoint, fr.placement, 0, c.anchor,
                pin.ReferenceFrame.LOCAL,
            )
        )  # fmt: skip
    cds = pin.StdVec_RigidConstraintData()
    for cm in cms:
        cds.append(cm.createData())
    data = m.createData()
    pin.initConstraintDynamics(m, data, cms, cds)
    a = pin.constraintDynamics(
        m, data, q, v, tau, cms, cds, pin.ProximalSettings(1e-14, 1e-14, 0, 1)
    )
    return a, np.concatenate([cd.contact_force.vector for cd in cds])


@pytest.mark.parametrize("name", ["male", "human"])
@pytest.mark.parametrize("mode", ["quaternion", "euler"])
def test_welded_feet_equal_pinocchio_constraint_dynamics(name, mode):
    """Random states with both feet welded where they are: same a and forces, 1e-8 relative."""
    h = get_model(name, mode)
    rng = np.random.default_rng(20)
    for _ in range(5):
        q, v = random_state(h, rng)
        tau = rng.normal(scale=20.0, size=h.nv)
        tau[:6] = 0.0
        constraints = _welds(h, q)
        ours = constrained_dynamics(h.model, h.model.createData(), q, v, tau, constraints)
        a, f = _pinocchio(h, q, v, tau, constraints)
        assert ours.method == "cholesky"
        assert np.abs(ours.a - a).max() <= 1e-8 * max(1.0, np.abs(a).max())
        assert np.abs(ours.forces - f).max() <= 1e-8 * max(1.0, np.abs(f).max())
        scale = max(1.0, np.abs(ours.a).max())
        assert ours.residual < 1e-8 * scale, f"relative residual {ours.residual / scale:.2e}"


def test_static_standing_forces_sum_to_weight():
    h = get_model("male", "quaternion")
    q = h.standing_configuration()
    v = np.zeros(h.nv)
    for constraints in (_welds(h, q), _points(h, q)):
        # joint torques that hold the pose: the joints' share of g with balanced base rows
        sol0 = constrained_dynamics(
            h.model, h.model.createData(), q, v, np.zeros(h.nv), constraints
        )
        fz = sum(f[2] for f in _world_forces(h, q, constraints, sol0.forces))
        weight = h.mass * 9.81
        # without torques the body accelerates, but the base's vertical equation still balances
        # when the pose is held: solve the static problem with the joint torques free
        data = h.model.createData()
        update_kinematics(h.model, data, q, v)
        J = np.vstack([c.jacobian(h.model, data) for c in constraints])
        g = pin.computeGeneralizedGravity(h.model, data, q)
        f_static = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]
        tau = g - J.T @ f_static
        tau[:6] = 0.0
        sol = constrained_dynamics(h.model, data, q, v, tau, constraints)
        assert np.abs(sol.a).max() < 1e-9, "the held pose should not accelerate"
        fz = sum(f[2] for f in _world_forces(h, q, constraints, sol.forces))
        assert fz == pytest.approx(weight, rel=1e-10)
        assert np.isfinite(sol0.forces).all()


def _world_forces(h, q, constraints, forces):
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, q)
    out, i = [], 0
    for c in constraints:
        f = forces[i : i + c.size]
        i += c.size
        if isinstance(c, Weld):
            out.append(data.oMf[c.frame_id].rotation @ f[:3])
        else:
            out.append(f)
    return out


@pytest.mark.parametrize("name", ["male_foot", "human"])
def test_redundant_point_contacts_stay_finite(name):
    """4 point contacts per flat one-piece foot on both feet: 24 rows of rank 12 (on a foot
    with toes the toe points turn on the MTP hinge: no longer redundant)."""
    h = get_model(name, "quaternion")
    rng = np.random.default_rng(21)
    q = h.standing_configuration()
    constraints = _points(h, q)
    data = h.model.createData()
    update_kinematics(h.model, data, q, np.zeros(h.nv))
    J = np.vstack([c.jacobian(h.model, data) for c in constraints])
    _, s, Vt = np.linalg.svd(J)
    assert (s > 1e-9 * s[0]).sum() == 12
    kernel = Vt[12:]  # velocities that keep all 24 rows consistent
    for trial in range(5):
        v = np.zeros(h.nv) if trial == 0 else kernel.T @ (0.5 * rng.normal(size=h.nv - 12))
        tau = np.zeros(h.nv)
        tau[6:] = rng.normal(scale=10.0, size=h.nv - 6)
        sol = constrained_dynamics(h.model, data, q, v, tau, constraints)
        assert sol.method == "eigen" and sol.rank == 12
        assert np.isfinite(sol.a).all() and np.isfinite(sol.forces).all()
        scale = max(1.0, np.abs(sol.a).max())
        assert sol.residual < 1e-8 * scale, f"constraint residual {sol.residual:.2e}"
        # minimum norm: no component of the forces in the null space of J^T
        _, s2, Wt = np.linalg.svd(J.T)
        null = Wt[12:]
        assert np.abs(null @ sol.forces).max() < 1e-6 * max(1.0, np.abs(sol.forces).max())
        # the accelerations equal those of the 12 independent rows (a weld per foot)
        ref = constrained_dynamics(h.model, h.model.createData(), q, v, tau, _welds(h, q))
        assert np.abs(sol.a - ref.a).max() < 1e-7 * max(1.0, np.abs(ref.a).max())
    # velocities that violate the contacts make the 24 rows inconsistent: still finite, and
    # the least-squares answer (no other acceleration satisfies the rows better)
    v = 0.1 * rng.normal(size=h.nv)
    sol = constrained_dynamics(h.model, data, q, v, tau, constraints)
    assert np.isfinite(sol.a).all() and np.isfinite(sol.forces).all()
    update_kinematics(h.model, data, q, v)
    J = np.vstack([c.jacobian(h.model, data) for c in constraints])
    gamma = -np.concatenate([c.drift(h.model, data) for c in constraints])
    Minv = np.linalg.inv(pin.crba(h.model, data, q))
    f = tau - pin.nle(h.model, data, q, v)
    lam = np.linalg.lstsq(J @ Minv @ J.T, gamma - J @ Minv @ f, rcond=1e-10)[0]
    best = np.abs(J @ (Minv @ (f + J.T @ lam)) - gamma)
    assert np.linalg.norm(J @ sol.a - gamma) <= np.linalg.norm(best) * (1 + 1e-6) + 1e-9


@pytest.mark.parametrize("name", ["male", "human"])
def test_straight_knees_both_feet_welded(name):
    """Near-singular: straight knees, loaded and unloaded, random velocities."""
    h = get_model(name, "quaternion")
    q = h.standing_configuration()  # knees at 0
    rng = np.random.default_rng(22)
    constraints = _welds(h, q)
    for scale in (0.0, 1.0):
        v = scale * rng.normal(size=h.nv)
        for load in (0.0, 200.0):
            tau = np.zeros(h.nv)
            tau[6:] = load * rng.normal(size=h.nv - 6)
            sol = constrained_dynamics(h.model, h.model.createData(), q, v, tau, constraints)
            assert np.isfinite(sol.a).all() and np.isfinite(sol.forces).all()
            assert sol.residual < 1e-8


def test_regularised_solve_is_minimum_norm_on_a_toy_problem():
    """Duplicate rows: the eigen fallback returns the min-norm split of the force."""
    Minv = np.diag([1.0, 2.0, 4.0])
    J = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    sol = solve_kkt(Minv, np.array([1.0, 1.0, 1.0]), J, np.array([0.0, 0.0, 0.0]))
    assert sol.method == "eigen" and sol.rank == 2
    assert np.allclose(sol.a, [0.0, 0.0, 4.0])
    assert np.allclose(sol.forces, [-0.5, -0.5, -1.0])


def _fd_check(h, constraint, q, rng):
    m = h.model
    data = m.createData()
    update_kinematics(m, data, q, np.zeros(m.nv))
    J = constraint.residual_jacobian(m, data)
    e0 = constraint.residual(m, data)
    eps = 1e-6
    for _ in range(3):
        dq = rng.normal(size=m.nv)
        ep, em = [], []
        for sign, out in ((1, ep), (-1, em)):
            d = m.createData()
            update_kinematics(m, d, pin.integrate(m, q, sign * eps * dq), np.zeros(m.nv))
            out.append(constraint.residual(m, d))
        fd = (ep[0] - em[0]) / (2 * eps)
        assert np.abs(fd - J @ dq).max() < 1e-6 * max(1.0, np.abs(fd).max()), constraint
    return e0


@pytest.mark.parametrize("name", ["male", "human"])
def test_jacobians_match_finite_differences_on_the_manifold(name):
    h = get_model(name, "quaternion")
    rng = np.random.default_rng(23)
    q, v = random_state(h, rng)
    m = h.model
    data = m.createData()
    pin.framesForwardKinematics(m, data, q)
    # anchors away from the current placement, so that residuals are not zero
    shift = pin.SE3(pin.exp3(np.array([0.1, -0.2, 0.05])), np.array([0.02, 0.01, -0.03]))
    fid = m.getFrameId(h.feet[0])
    weld = Weld("w", fid, data.oMf[fid] * shift)
    point = PointContact("p", m.getFrameId(h.contact_points["right"][2]), np.array([0.1, 0, 0]))
    for c in (weld, point):
        _fd_check(h, c, q, rng)
    # drift: J'v by finite differences of J along v (J(q + eps v) v - J(q - eps v) v) / 2 eps
    eps = 1e-6
    for c in (weld, point):
        update_kinematics(m, data, q, v)
        drift = c.drift(m, data)
        Js = []
        for sign in (1, -1):
            d = m.createData()
            update_kinematics(m, d, pin.integrate(m, q, sign * eps * v), v)
            Js.append(c.jacobian(m, d))
        if isinstance(c, Weld):
            # the LOCAL Jacobian's own derivative: J'v = d/dt (J v) at a = 0
            fd = (Js[0] @ v - Js[1] @ v) / (2 * eps)
        else:
            fd = (Js[0] @ v - Js[1] @ v) / (2 * eps)
        assert np.abs(fd - drift).max() < 1e-5 * max(1.0, np.abs(drift).max()), c


def test_baumgarte_pulls_residuals_back():
    """With a perturbed anchor, Baumgarte's acceleration opposes the error."""
    h = get_model("male", "quaternion")
    q = h.standing_configuration()
    m = h.model
    data = m.createData()
    pin.framesForwardKinematics(m, data, q)
    fid = m.getFrameId(h.feet[0])
    c = PointContact("p", m.getFrameId(h.contact_points["left"][0]), np.zeros(3))
    c.anchor = data.oMf[c.frame_id].translation + np.array([0.0, 0.0, 1e-3])
    bg = Baumgarte.from_time_constant(0.02)
    sol = constrained_dynamics(m, data, q, np.zeros(m.nv), np.zeros(m.nv), [c], bg)
    update_kinematics(m, data, q, np.zeros(m.nv))
    acc = c.jacobian(m, data) @ sol.a + c.drift(m, data)
    # e'' = -beta^2 e = -(1/0.02)^2 * (-1e-3) in z
    assert acc[2] == pytest.approx(1e-3 / 0.02**2, rel=1e-9)
    assert fid >= 0


def test_ball_on_a_rod_conical_pendulum():
    """The seeds' ball on a rod, e(x) = x.x - 1 = 0, with gravity: a conical pendulum.

    Analytic: at polar angle theta from the downward vertical, uniform circular motion with
    Omega^2 = g / (L cos theta) and rod tension m g / cos theta.
    """
    m, g, L, theta = 2.0, 9.81, 1.0, 0.6
    omega = np.sqrt(g / (L * np.cos(theta)))
    x = np.array([L * np.sin(theta), 0.0, -L * np.cos(theta)])
    xd = np.array([0.0, omega * L * np.sin(theta), 0.0])
    Minv = np.eye(3) / m
    f = np.array([0.0, 0.0, -m * g])
    forces = []

    def acc(t, x, xd):
        J = 2.0 * x[None, :]
        sol = solve_kkt(Minv, f, J, np.array([-2.0 * xd @ xd]))
        forces.append(sol.forces[0] * np.linalg.norm(J))
        return sol.a

    space = CoordinateSpace(3)
    dt, T = 1e-3, 2 * np.pi / omega * 3  # three revolutions
    steps = int(round(T / dt))
    for k in range(steps):
        x, xd = rk4(space, acc, k * dt, x, xd, dt)
    t_end = steps * dt
    expected = np.array(
        [L * np.sin(theta) * np.cos(omega * t_end), L * np.sin(theta) * np.sin(omega * t_end),
         -L * np.cos(theta)]
    )  # fmt: skip
    assert np.abs(x - expected).max() < 1e-8
    assert abs(x @ x - 1.0) < 1e-9
    tension = m * g / np.cos(theta)  # magnitude of the rod force (pointing to the pivot)
    forces.clear()
    a = acc(t_end, x, xd)
    assert abs(forces[0]) == pytest.approx(tension, rel=1e-8)
    assert np.allclose(a, -(omega**2) * np.array([x[0], x[1], 0.0]), atol=1e-7)


def test_coordinate_map_velocity_and_norm_constraint():
    h = get_model("male", "quaternion")
    cm = CoordinateMap(h.model)
    rng = np.random.default_rng(24)
    q, v = random_state(h, rng)
    x, xd = cm.from_tangent(q, v)
    assert np.allclose(cm.H(x) @ xd, v, atol=1e-12)
    # x' is the derivative of q along v
    eps = 1e-7
    fd = (pin.integrate(h.model, q, eps * v) - pin.integrate(h.model, q, -eps * v)) / (2 * eps)
    assert np.allclose(xd, fd, atol=1e-6)
    norm = QuaternionNorm(cm)
    assert norm.size == 8  # free flyer + 7 ball joints
    assert np.abs(norm.residual(x)).max() < 1e-12
    assert np.abs(norm.jacobian(x) @ xd).max() < 1e-12  # unit-norm preserving velocity


def test_the_quaternion_norms_jacobian_and_drift_match_finite_differences():
    """e = |Q|^2 - 1: J = de/dx = 2 Q^T and the drift J' x' = 2 |Q'|^2, checked by central
    differences off the unit sphere and with an x' that changes the norm (on it, J x' = 0
    hides a J off by any factor; planted, J = Q^T and a drift of |Q'|^2 passed the test
    above)."""
    h = get_model("male", "quaternion")
    cm = CoordinateMap(h.model)
    norm = QuaternionNorm(cm)
    rng = np.random.default_rng(25)
    q, v = random_state(h, rng)
    x, _ = cm.from_tangent(q, v)
    x = x + 0.05 * rng.normal(size=len(x))  # off the unit sphere
    xd = rng.normal(size=len(x))
    eps = 1e-6
    J = norm.jacobian(x)
    fd = np.column_stack([(norm.residual(x + eps * d) - norm.residual(x - eps * d)) / (2 * eps)
                          for d in np.eye(len(x))])  # fmt: skip
    np.testing.assert_allclose(J, fd, atol=1e-8)
    # d/dt (J(x + t x') x') at t = 0
    fd_drift = (norm.jacobian(x + eps * xd) @ xd - norm.jacobian(x - eps * xd) @ xd) / (2 * eps)
    np.testing.assert_allclose(norm.drift(xd), fd_drift, rtol=1e-7, atol=1e-8)
    assert np.abs(norm.drift(xd)).min() > 0.1


@pytest.mark.parametrize("name", ["male", "human"])
def test_weld_wrench_is_in_world_axes_on_a_tilted_foot(name):
    """The weld's lambda (LOCAL axes) and its world wrench do the same work: J_local^T lambda
    equals J_world^T w with J_world the sole frame's Jacobian in world-aligned axes and w the
    wrench (force, torque about the sole origin) in world axes; the foot is tilted, so sole and
    world axes differ in every direction."""
    h = get_model(name, "quaternion")
    m, data = h.model, h.model.createData()
    rng = np.random.default_rng(61)
    for _ in range(3):
        q, _ = random_state(h, rng)
        update_kinematics(m, data, q, np.zeros(m.nv))
        weld = _welds(h, q, data)[0]
        R = data.oMf[weld.frame_id].rotation
        assert np.abs(R - np.eye(3)).max() > 0.1  # tilted
        lam = rng.normal(size=6) * [100, 100, 600, 20, 20, 5]
        w = weld.wrench_world(m, data, lam)
        J_world = pin.getFrameJacobian(m, data, weld.frame_id, pin.LOCAL_WORLD_ALIGNED)
        np.testing.assert_allclose(weld.jacobian(m, data).T @ lam, J_world.T @ w, atol=1e-9)


def test_projection_leaves_the_velocity_on_the_constraint_manifold():
    """After the projection of a perturbed state, the welds hold in position (|e| < 1e-12) and
    in velocity (J v = 0, the projection's velocity impulse)."""
    from conftest import BODIES

    from humanoid.scene import Contact, Effects, Scene
    from humanoid.simulation import Simulation

    scene = Scene(body=str(BODIES / "adult_male.urdf"),
                  effects=Effects(contacts=(Contact("left"), Contact("right"))))  # fmt: skip
    sim = Simulation(scene)
    rng = np.random.default_rng(62)
    q0, v0 = sim.q0, sim.switch_contacts(0.0, sim.q0, sim.v0, {"left", "right"})
    q = pin.integrate(sim.model, q0, 1e-3 * rng.normal(size=sim.model.nv))
    v = v0 + 0.5 * rng.normal(size=sim.model.nv)
    q2, v2 = sim.project(q, v)
    update_kinematics(sim.model, sim.data, q2, v2)
    cs = sim.active_constraints()
    assert len(cs) == 4  # a weld and the lock of its toes' hinge per foot
    e = np.concatenate([c.residual(sim.model, sim.data) for c in cs])
    J = np.vstack([c.jacobian(sim.model, sim.data) for c in cs])
    assert np.abs(e).max() < 1e-12
    assert np.abs(J @ v2).max() < 1e-9
    assert np.abs(J @ v).max() > 0.1  # there was something to remove
