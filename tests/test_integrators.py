"""Integrators on the configuration Lie group: measured orders of convergence, adaptive control."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model

from humanoid.errors import DivergenceError
from humanoid.integrators import (
    CoordinateSpace,
    DormandPrince,
    LieGroupSpace,
    explicit_euler,
    rk4,
    semi_implicit_euler,
)

T = 0.4  # [s]


@pytest.fixture(scope="module")
def tumble():
    """A smooth scene: our body tumbling in zero gravity with moving joints."""
    h = get_model("male", "quaternion")
    model = h.model.copy()
    model.gravity = pin.Motion.Zero()
    data = model.createData()
    rng = np.random.default_rng(30)
    q0 = h.standing_configuration()
    v0 = np.zeros(model.nv)
    v0[3:6] = [0.5, 1.5, 0.3]
    v0[6:] = 0.3 * rng.normal(size=model.nv - 6)
    tau = np.zeros(model.nv)

    def f(t, q, v):
        return pin.aba(model, data, q, v, tau).copy()

    space = LieGroupSpace(model)
    ref = DormandPrince(rtol=1e-13, atol=1e-13, max_step=0.01)
    q_ref, v_ref = ref.advance(space, f, 0.0, q0, v0, T)
    return model, space, f, q0, v0, q_ref, v_ref


def _error(model, q, v, q_ref, v_ref):
    return max(np.abs(pin.difference(model, q, q_ref)).max(), np.abs(v - v_ref).max())


def _run(scheme, space, f, q, v, dt):
    for k in range(int(round(T / dt))):
        q, v = scheme(space, f, k * dt, q, v, dt)
    return q, v


@pytest.mark.parametrize(
    ("scheme", "order", "dts"),
    [
        (explicit_euler, 1, (2e-3, 1e-3, 5e-4)),
        (semi_implicit_euler, 1, (2e-3, 1e-3, 5e-4)),
        (rk4, 4, (2e-2, 1e-2, 5e-3)),
    ],
)
def test_measured_order_matches_the_scheme(tumble, scheme, order, dts):
    model, space, f, q0, v0, q_ref, v_ref = tumble
    errors = [_error(model, *_run(scheme, space, f, q0, v0, dt), q_ref, v_ref) for dt in dts]
    orders = [np.log2(errors[i] / errors[i + 1]) for i in range(len(errors) - 1)]
    assert all(abs(p - order) < 0.3 for p in orders), f"errors {errors}, measured orders {orders}"


def test_reference_solution_converged(tumble):
    """The DP5(4) reference at 1e-13 agrees with one at 1e-11 and with fine RK4 (0.5 ms: the
    toes, 0.16 kg on the MTP hinge, are the fastest part; RK4 errs most on their velocity)."""
    model, space, f, q0, v0, q_ref, v_ref = tumble
    looser = DormandPrince(rtol=1e-11, atol=1e-11, max_step=0.01)
    q1, v1 = looser.advance(space, f, 0.0, q0, v0, T)
    assert _error(model, q1, v1, q_ref, v_ref) < 1e-9
    q2, v2 = _run(rk4, space, f, q0, v0, 5e-4)
    assert _error(model, q2, v2, q_ref, v_ref) < 1e-9


def test_adaptive_meets_its_tolerance_and_counts(tumble):
    model, space, f, q0, v0, q_ref, v_ref = tumble
    errs = []
    for rtol in (1e-4, 1e-6, 1e-8):
        dp = DormandPrince(rtol=rtol, atol=rtol, max_step=0.05)
        q, v = dp.advance(space, f, 0.0, q0, v0, T)
        errs.append(_error(model, q, v, q_ref, v_ref))
        s = dp.stats
        assert s.accepted > 0 and s.evaluations == 7 * (s.accepted + s.rejected)
        assert s.smallest_step <= s.largest_step <= 0.05
        assert errs[-1] < 100 * rtol, f"rtol {rtol}: error {errs[-1]:.2e}"
    assert errs[0] > errs[1] > errs[2]


def test_adaptive_rejects_steps_on_a_sudden_change():
    space = CoordinateSpace(1)

    def f(t, q, v):  # a stiff kick: the controller must shrink the step and reject some
        return -1e4 * q

    dp = DormandPrince(rtol=1e-8, atol=1e-10, max_step=0.1)
    q, v = dp.advance(space, f, 0.0, np.array([1.0]), np.array([0.0]), 0.05)
    assert dp.stats.rejected > 0
    assert q[0] == pytest.approx(np.cos(100 * 0.05), abs=1e-6)


def test_adaptive_stops_with_a_clear_error_when_the_step_collapses():
    space = CoordinateSpace(1)

    def f(t, q, v):
        return np.array([np.nan])

    dp = DormandPrince(min_step=1e-6)
    with pytest.raises(DivergenceError, match="adaptive step fell below"):
        dp.advance(space, f, 0.0, np.array([1.0]), np.array([0.0]), 1.0)


def test_dexp_inverse_matches_pinocchio():
    h = get_model("human", "quaternion")
    space = LieGroupSpace(h.model)
    rng = np.random.default_rng(31)
    q = pin.integrate(h.model, pin.neutral(h.model), rng.normal(size=h.nv))
    q[:3] = 0.0
    for _ in range(3):
        d, w = rng.normal(size=h.nv), rng.normal(size=h.nv)
        expected = np.linalg.solve(pin.dIntegrate(h.model, q, d, pin.ArgumentPosition.ARG1), w)
        assert np.abs(space.dexp_inv(d, w) - expected).max() < 1e-12


def test_order_holds_with_a_time_dependent_force(tumble):
    """Stage times matter: joint torques tau(t) = A sin(w t) that vary within a step. RK4 and
    DP5 keep their orders only if every stage is evaluated at its own time (an RK4 whose last
    stage is taken at t + dt/2 drops to order 1 here)."""
    model, space, _, q0, v0, _, _ = tumble
    data = model.createData()
    amplitude = 2.0 * np.diag(pin.crba(model, data, q0)).copy()  # [N m]: about 2 rad/s^2
    amplitude[:6] = 0.0

    def f(t, q, v):
        return pin.aba(model, data, q, v, amplitude * np.sin(15.0 * t)).copy()

    q_ref, v_ref = DormandPrince(rtol=1e-13, atol=1e-13, max_step=0.005).advance(
        space, f, 0.0, q0, v0, T
    )
    dts = (5e-3, 2.5e-3, 1.25e-3)  # inside RK4's asymptotic range on the toes' fast motion
    errors = [_error(model, *_run(rk4, space, f, q0, v0, dt), q_ref, v_ref) for dt in dts]
    orders = [np.log2(errors[i] / errors[i + 1]) for i in range(len(errors) - 1)]
    assert all(abs(p - 4) < 0.3 for p in orders), f"errors {errors}, measured orders {orders}"
    errs = []
    for rtol in (1e-5, 1e-7):
        q, v = DormandPrince(rtol=rtol, atol=rtol, max_step=0.05).advance(space, f, 0.0, q0, v0, T)
        errs.append(_error(model, q, v, q_ref, v_ref))
    assert errs[0] < 100 * 1e-5 and errs[1] < 100 * 1e-7, errs


@pytest.mark.parametrize(("scheme", "bounded"), [(semi_implicit_euler, True),
                                                 (explicit_euler, False)])  # fmt: skip
def test_symplectic_euler_keeps_energy_bounded_explicit_does_not(scheme, bounded):
    """Both Euler schemes are order 1; only the symplectic one keeps the energy of a
    conservative system bounded over long times. A harmonic oscillator (q'' = -q) over 100
    periods at dt = 0.05: semi-implicit Euler stays within dt/2 of the initial energy (its
    modified energy is exact), explicit Euler grows by (1 + dt^2) per step, a factor 2e3."""
    space = CoordinateSpace(1)
    dt, q, v = 0.05, np.array([1.0]), np.array([0.0])
    worst = 0.0
    for k in range(int(round(200 * np.pi / dt))):
        q, v = scheme(space, lambda t, q, v: -q, k * dt, q, v, dt)
        worst = max(worst, abs(0.5 * (q[0] ** 2 + v[0] ** 2) - 0.5))
    if bounded:
        assert worst < dt / 2
    else:
        assert worst > 100.0
