"""Hinge triplets fused into spherical joints: same mechanics, no gimbal lock."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model, random_state

import humanoid as hm

FUSED = ("male", "female", "human")


def _energies(model, q, v):
    data = model.createData()
    return pin.computeKineticEnergy(model, data, q, v), pin.computePotentialEnergy(model, data, q)


def _body_placements(model, q):
    """World placements of the massive bodies, by link name."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return {
        f.name: data.oMf[i].homogeneous.copy()
        for i, f in enumerate(model.frames)
        if f.type == pin.FrameType.BODY and model.inertias[f.parentJoint].mass > 0
    }


def test_expected_joints_are_fused():
    male = get_model("male", "quaternion")
    assert sorted(b.name for b in male.fusion.balls) == sorted(
        ["lumbar", "thoracic", "neck", "left_hip", "right_hip", "left_shoulder", "right_shoulder"]
    )
    human = get_model("human", "quaternion")
    # erd human: hips, shoulders, thoracic and cervical are ZXY triplets; lumbar has 2 hinges
    assert sorted(b.name for b in human.fusion.balls) == sorted(
        ["left_hip", "right_hip", "left_shoulder", "right_shoulder", "middle_thoracic",
         "middle_cervical"]
    )  # fmt: skip
    talos = get_model("talos", "quaternion")
    assert talos.fusion.balls == ()  # its hip axes do not meet at one point
    for h in (male, human):
        assert h.nv == h.euler_model.nv
        assert h.mass == pytest.approx(sum(i.mass for i in h.euler_model.inertias), rel=1e-15)


@pytest.mark.parametrize("name", FUSED)
def test_energies_agree(name):
    h = get_model(name, "quaternion")
    rng = np.random.default_rng(10)
    for _ in range(20):
        qe, ve = random_state(get_model(name, "euler"), rng)
        q, v = h.from_euler(qe, ve)
        ke_e, pe_e = _energies(h.euler_model, qe, ve)
        ke, pe = _energies(h.model, q, v)
        assert abs(ke - ke_e) < 1e-10 * max(1.0, ke_e)
        assert abs(pe - pe_e) < 1e-10 * max(1.0, abs(pe_e))
        # every massive body is in the same place
        pe_bodies, pq_bodies = _body_placements(h.euler_model, qe), _body_placements(h.model, q)
        for link, T in pe_bodies.items():
            assert np.abs(pq_bodies[link] - T).max() < 1e-12, link


@pytest.mark.parametrize("name", FUSED)
def test_state_round_trip(name):
    h = get_model(name, "quaternion")
    rng = np.random.default_rng(11)
    for _ in range(20):
        qe, ve = random_state(get_model(name, "euler"), rng)
        q, v = h.from_euler(qe, ve)
        qe2, ve2 = h.to_euler(q, v, hint=qe)
        assert np.abs(qe2 - qe).max() < 1e-9
        assert np.abs(ve2 - ve).max() < 1e-8
        q3, v3 = h.from_euler(qe2, ve2)
        assert np.abs(pin.difference(h.model, q, q3)).max() < 1e-9


def test_velocity_map_matches_finite_differences():
    h = get_model("human", "quaternion")
    rng = np.random.default_rng(12)
    eps = 1e-7
    for ball in h.fusion.balls:
        th = rng.uniform(-1.0, 1.0, 3)
        rate = rng.normal(size=3)
        R0, R1 = ball.rotation(th - eps * rate), ball.rotation(th + eps * rate)
        omega_fd = pin.log3(R0.T @ R1) / (2 * eps)
        assert np.allclose(ball.velocity_map(th) @ rate, omega_fd, atol=1e-7), ball.name


def _rk4(model, q, v, tau, dt, steps):
    """Classical RK4 in the Munthe-Kaas form (stages in the tangent space at the step start),
    fourth order on the configuration Lie group."""

    def acc(q, v):
        return pin.aba(model, model.createData(), q, v, tau)

    for _ in range(steps):
        dq, dv, d = [], [], np.zeros(model.nv)
        for c in (0.0, 0.5, 0.5, 1.0):
            d = c * dt * dq[-1] if dq else d
            qs = pin.integrate(model, q, d)
            vs = v + c * dt * dv[-1] if dv else v
            J = pin.dIntegrate(model, q, d, pin.ARG1)
            dq.append(np.linalg.solve(J, vs))
            dv.append(acc(qs, vs))
        w = np.array([1.0, 2.0, 2.0, 1.0]) * dt / 6
        q = pin.integrate(model, q, sum(wi * k for wi, k in zip(w, dq, strict=True)))
        v = v + sum(wi * k for wi, k in zip(w, dv, strict=True))
    return q, v


@pytest.mark.parametrize("name", ["male", "human"])
def test_same_motion_under_same_forces(name):
    """Gravity and the same torques on the non-fused joints: the same motion for 0.2 s."""
    h = get_model(name, "quaternion")
    he = get_model(name, "euler")
    rng = np.random.default_rng(13)
    qe, ve = random_state(he, rng)
    ve *= 0.3
    q, v = h.from_euler(qe, ve)
    tau_e = np.zeros(he.nv)
    tau = np.zeros(h.nv)
    for je, jf in h.fusion.copied:
        a, b = he.model.joints[je], h.model.joints[jf]
        if a.nv == 1:
            t = rng.normal(scale=0.5)
            tau_e[a.idx_v], tau[b.idx_v] = t, t
    errors = []
    for dt in (1e-3, 5e-4):
        steps = round(0.2 / dt)
        qe_T, _ = _rk4(he.model, qe, ve, tau_e, dt, steps)
        q_T, _ = _rk4(h.model, q, v, tau, dt, steps)
        pe, pq = _body_placements(he.model, qe_T), _body_placements(h.model, q_T)
        errors.append(max(np.abs(pq[k][:3, 3] - T[:3, 3]).max() for k, T in pe.items()))
    # Both integrate the same ODE in other coordinates: they differ by RK4's O(dt^4) error only.
    assert errors[1] < 1e-7, f"body positions differ by {errors[1]:.2e} m after 0.2 s"
    assert errors[0] / errors[1] > 8.0, f"difference does not shrink as dt^4: {errors}"


def test_fused_model_is_well_conditioned_at_erd_hip_gimbal_lock():
    """erd's hip X limit is pi/2 - 1.3e-6: the Euler model's M is singular there."""
    he = get_model("human", "euler")
    h = get_model("human", "quaternion")
    m = he.model
    qe = he.standing_configuration()
    for side in ("left", "right"):
        jm = m.joints[m.getJointId(f"{side}_hip_X")]
        qe[jm.idx_q] = m.upperPositionLimit[jm.idx_q]
    assert abs(m.upperPositionLimit[m.joints[m.getJointId("left_hip_X")].idx_q] - np.pi / 2) < 2e-6
    cond_euler = np.linalg.cond(hm.mass_matrix(he, qe))
    q, _ = h.from_euler(qe)
    cond_fused = np.linalg.cond(hm.mass_matrix(h, q))
    assert cond_euler > 1e12, f"cond(M) Euler = {cond_euler:.3e}"
    assert cond_fused < 1e6, f"cond(M) fused = {cond_fused:.3e}"
    # Hinge rates are undefined exactly there: the conversion says so instead of dividing by 0.
    qe[m.joints[m.getJointId("left_hip_X")].idx_q] = np.pi / 2
    q, v = h.from_euler(qe, np.zeros(he.nv))
    v[h.model.joints[h.model.getJointId("left_hip")].idx_v] = 1.0
    with pytest.raises(hm.ConfigurationError, match="gimbal lock"):
        h.to_euler(q, v)


def test_euler_mode_keeps_urdf_joints():
    he = get_model("male", "euler")
    assert he.fusion is None and he.model is he.euler_model
    assert he.model.nv == he.model.nq - 1 == 41
    assert all(j.nq == 1 for j in he.model.joints[2:])


def test_to_euler_and_back_take_sequences_of_states():
    h = get_model("male", "quaternion")
    rng = np.random.default_rng(5)
    q0 = h.standing_configuration()
    qs = np.array([pin.integrate(h.model, q0, 0.3 * rng.normal(size=h.nv)) for _ in range(4)])
    vs = rng.normal(size=(4, h.nv))
    qe, ve = h.to_euler(qs, vs)
    assert qe.shape == (4, h.euler_model.nq) and ve.shape == (4, h.euler_model.nv)
    for i in range(4):
        one_q, one_v = h.to_euler(qs[i], vs[i], hint=qe[i - 1] if i else None)
        assert np.allclose(one_q, qe[i]) and np.allclose(one_v, ve[i])
    back_q, back_v = h.from_euler(qe, ve)
    assert back_q.shape == qs.shape
    for a, b in zip(back_q, qs, strict=True):
        assert np.allclose(pin.difference(h.model, a, b), 0.0, atol=1e-9)
    assert np.allclose(back_v, vs, atol=1e-9)
    empty_q, empty_v = h.to_euler(np.zeros((0, h.nq)))
    assert empty_q.shape == (0, h.euler_model.nq) and empty_v is None


def test_the_balls_quaternions_and_velocities_are_their_rotations_and_maps_at_any_angle():
    """:meth:`Fusion.to_quaternion` (all balls at once) against each ball's own
    :meth:`BallJoint.rotation` and :meth:`BallJoint.velocity_map`, at random angles over the
    whole circle (rotations past 90 degrees, where the trace is negative and Eigen's other
    branches give the quaternion): equal to 1e-14, the quaternion's w the same sign."""
    rng = np.random.default_rng(7)
    for name in ("male", "human"):
        h = get_model(name, "quaternion")
        f = h.fusion
        em = f.euler_model
        negative = 0
        for _ in range(200):
            qe = pin.neutral(em)
            qe[7:] = rng.uniform(-np.pi, np.pi, em.nq - 7)
            ve = rng.normal(size=em.nv)
            q, v = f.to_quaternion(qe, ve)
            for ball in f.balls:
                jm = f.model.joints[ball.joint_id]
                th = qe[[em.joints[j].idx_q for j in ball.hinge_ids]]
                Rs = ball.rotation(th)
                negative += np.trace(Rs) <= 0.0
                want = pin.Quaternion(Rs).coeffs()
                np.testing.assert_allclose(q[jm.idx_q : jm.idx_q + 4], want, atol=1e-14)
                rates = ve[[em.joints[j].idx_v for j in ball.hinge_ids]]
                np.testing.assert_allclose(v[jm.idx_v : jm.idx_v + 3],
                                           ball.velocity_map(th) @ rates, atol=1e-13)  # fmt: skip
        assert negative > 50  # the other branches were taken


def test_states_map_at_once_as_one_by_one():
    """:meth:`Fusion.to_quaternion` and :meth:`OcpModel.to_body` of a sequence (N, n) at once
    equal the maps of its states one by one (to 1e-15); the free flyer's twist (closed form)
    is the OCP root's forward kinematics at any heading (the pelvis turned round, yaw in
    [-3, 3] rad); a bad row is named."""
    from humanoid.errors import ConfigurationError
    from humanoid.optimal.coordinates import build_ocp_model, root_rotations

    rng = np.random.default_rng(11)
    h = get_model("male", "quaternion")
    em = h.fusion.euler_model
    qe = np.tile(pin.neutral(em), (20, 1))
    qe[:, 7:] = rng.uniform(-np.pi, np.pi, (20, em.nq - 7))
    ve = rng.normal(size=(20, em.nv))
    q, v = h.fusion.to_quaternion(qe, ve)
    for i in range(20):
        qi, vi = h.fusion.to_quaternion(qe[i], ve[i])
        np.testing.assert_allclose(q[i], qi, atol=1e-15)
        np.testing.assert_allclose(v[i], vi, atol=1e-15)
    om = build_ocp_model(h)
    x = om.from_body(h.standing_configuration()) + 0.3 * rng.standard_normal((20, om.n))
    x[:, 3] = rng.uniform(-3.0, 3.0, 20)
    xv = rng.standard_normal((20, om.n))
    qb, vb = om.to_body(x, xv)
    data = om.model.createData()
    for row, R in zip(x[:, 3:6], root_rotations(x[:, 3:6]), strict=True):
        np.testing.assert_allclose(R, pin.rpy.rpyToMatrix(row[2], row[1], row[0]), atol=1e-15)
    for i in range(20):
        qi, vi = om.to_body(x[i], xv[i])
        np.testing.assert_allclose(qb[i], qi, atol=1e-15)
        np.testing.assert_allclose(vb[i], vi, atol=1e-15)
        pin.forwardKinematics(om.model, data, x[i], xv[i])
        np.testing.assert_allclose(vi[:6], data.v[6].vector, atol=1e-12)
    bad = qe.copy()
    bad[3, 9] = np.nan
    with pytest.raises(ConfigurationError, match=r"q has non-finite entries \(at \[9\]\)"):
        h.fusion.to_quaternion(bad)
    with pytest.raises(ConfigurationError, match="v has 19 rows for 20 states"):
        h.fusion.to_quaternion(qe, ve[1:])
