"""Equations of motion: CRBA/RNEA against the seeds' projected Newton-Euler sums, and identities."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import ALL_MODELS, get_model, random_state

import humanoid as hm

TOL = 1e-9  # absolute, on entries of order 1-1000 (N, N m, kg m^2)


@pytest.mark.parametrize(("name", "mode"), ALL_MODELS)
def test_projected_newton_euler_equals_crba_rnea(name, mode):
    h = get_model(name, mode)
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(5):
        q, v = random_state(h, rng)
        M = hm.mass_matrix(h, q)
        b = hm.bias_forces(h, q, v)
        g = hm.gravity_forces(h, q)
        M_ne, c_ne, g_ne = hm.projected_newton_euler(h, q, v)
        err = max(np.abs(M - M_ne).max(), np.abs(b - (c_ne + g_ne)).max(), np.abs(g - g_ne).max())
        worst = max(worst, err)
    assert worst < TOL, f"{name}/{mode}: max |CRBA/RNEA - projected NE| = {worst:.2e}"


@pytest.mark.parametrize(("name", "mode"), ALL_MODELS)
def test_mass_matrix_spd_and_energy(name, mode):
    h = get_model(name, mode)
    rng = np.random.default_rng(2)
    for _ in range(5):
        q, v = random_state(h, rng)
        M = hm.mass_matrix(h, q)
        assert np.array_equal(M, M.T)
        assert np.linalg.eigvalsh(M)[0] > 0.0
        ke = hm.kinetic_energy(h, q, v)
        assert ke == pytest.approx(0.5 * v @ M @ v, rel=1e-12)


@pytest.mark.parametrize(("name", "mode"), ALL_MODELS)
def test_rnea_inverts_aba(name, mode):
    h = get_model(name, mode)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, v = random_state(h, rng)
        tau = rng.normal(scale=10.0, size=h.nv)
        a = pin.aba(h.model, h.data, q, v, tau)
        tau_back = pin.rnea(h.model, h.data, q, v, a)
        assert np.abs(tau_back - tau).max() < 1e-8 * max(1.0, np.abs(tau).max())
        # and M a + b = tau with our wrappers
        lhs = hm.mass_matrix(h, q) @ a + hm.bias_forces(h, q, v)
        assert np.abs(lhs - tau).max() < 1e-8 * max(1.0, np.abs(tau).max())


@pytest.mark.parametrize(("name", "mode"), [("male", "quaternion"), ("human", "euler")])
def test_momentum_and_potential_energy(name, mode):
    h = get_model(name, mode)
    rng = np.random.default_rng(4)
    q, v = random_state(h, rng)
    linear, angular = hm.centroidal_momentum(h, q, v)
    # linear momentum = m * CoM velocity, CoM velocity by finite differences on the manifold
    eps = 1e-6
    c1 = hm.centre_of_mass(h, pin.integrate(h.model, q, eps * v))
    c0 = hm.centre_of_mass(h, pin.integrate(h.model, q, -eps * v))
    assert np.allclose(linear, h.mass * (c1 - c0) / (2 * eps), atol=1e-6)
    # potential energy = -m g0 . c
    pe = hm.potential_energy(h, q)
    assert pe == pytest.approx(-h.mass * h.model.gravity.linear @ hm.centre_of_mass(h, q))
    # angular momentum about the CoM is unchanged by adding a uniform base translation rate
    v2 = v.copy()
    v2[:3] += pin.Quaternion(q[3:7]).toRotationMatrix().T @ np.array([1.0, -2.0, 0.5])
    assert np.allclose(hm.centroidal_momentum(h, q, v2)[1], angular, atol=1e-9)


def test_gravity_only_acts_through_the_base_when_standing():
    h = get_model("male", "quaternion")
    q = h.standing_configuration()
    g = hm.gravity_forces(h, q)
    # The vertical base force equals the weight [N].
    assert g[2] == pytest.approx(h.mass * 9.81, rel=1e-12)


def test_bad_state_is_rejected():
    h = get_model("male", "quaternion")
    q = h.standing_configuration()
    with pytest.raises(hm.ConfigurationError, match="nq = 49"):
        hm.mass_matrix(h, q[:-1])
    q[5] = np.nan
    with pytest.raises(hm.ConfigurationError, match="non-finite"):
        hm.gravity_forces(h, q)
    with pytest.raises(hm.ConfigurationError, match="nv = 41"):
        hm.bias_forces(h, h.standing_configuration(), np.zeros(3))


@pytest.mark.parametrize("name", ["male", "talos"])
def test_pinocchio_returns_both_triangles_of_m_and_its_inverse(name):
    """The code takes ``pin.crba`` and ``pin.computeMinverse`` as full symmetric matrices (the
    bindings fill the lower triangle; the C++ data holds only the upper one): checked on random
    states, exactly."""
    h = get_model(name, "quaternion")
    rng = np.random.default_rng(5)
    data = h.model.createData()
    for _ in range(3):
        q, _ = random_state(h, rng)
        M = pin.crba(h.model, data, q)
        Minv = pin.computeMinverse(h.model, data, q)
        assert np.array_equal(M, M.T) and np.array_equal(Minv, Minv.T)
        assert np.abs(np.tril(M, -1)).max() > 0  # the lower triangle is there, not zero
        assert np.allclose(M @ Minv, np.eye(h.nv), atol=1e-8)


def test_centre_of_pressure_finds_the_point_a_force_acts_at():
    """A force applied at c = (x, y, h) with a free moment about z, as a wrench about the
    origin: its centre of pressure on z = h is (x, y) (seeded, 20 wrenches; a planted sign in
    either row moves it); a wrench without vertical force has none (NaN)."""
    from humanoid.dynamics import centre_of_pressure

    rng = np.random.default_rng(7)
    for height in (0.0, 0.04):
        c = np.column_stack([rng.uniform(-1, 1, (20, 2)), np.full(20, height)])
        f = rng.normal(size=(20, 3)) * [80.0, 80.0, 300.0] + [0.0, 0.0, 700.0]
        tz = rng.normal(size=20) * 5.0
        m = np.cross(c, f) + np.column_stack([np.zeros((20, 2)), tz])
        np.testing.assert_allclose(centre_of_pressure(np.hstack([f, m]), height), c[:, :2],
                                   atol=1e-12)  # fmt: skip
    assert np.isnan(centre_of_pressure([0.0, 0.0, 0.0, 1.0, 2.0, 3.0])).all()
