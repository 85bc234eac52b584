"""The welded walk's checks computed after the run (WalkMonitor.series_until): each batch
computation against the per-tick one it replaces (Pinocchio and the joint ranges state by
state), and the fall test at the tick it happens."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model

import humanoid.walking.run as walk_run
from humanoid.constraints.limits import JointRanges, _wrap, _wrap_in_place, range_violations
from humanoid.dynamics import TreeDynamics
from humanoid.errors import RunFailed
from humanoid.simulation import StepResult
from humanoid.walking import GaitParameters, walk


@pytest.fixture(scope="module")
def male():
    return get_model("male", "quaternion")


@pytest.fixture(scope="module")
def walked(male):
    """A short walk and the monitor that watched it."""
    seen = []

    class Monitor(walk_run.WalkMonitor):
        def __init__(self, *args) -> None:
            super().__init__(*args)
            seen.append(self)

    original, walk_run.WalkMonitor = walk_run.WalkMonitor, Monitor
    try:
        result = walk(male, GaitParameters(steps=2), quiet=True)
    finally:
        walk_run.WalkMonitor = original
    assert result.trajectory.status == "completed"
    return result, seen[0]


def test_log6_linear_is_pinocchios():
    rng = np.random.default_rng(5)
    placements = [pin.SE3.Random() for _ in range(400)]
    for scale in (1e-1, 1e-3, 1e-5, 1e-8, 0.0):  # near the identity: the welds' drift
        placements += [pin.SE3(pin.exp3(rng.normal(size=3) * scale), rng.normal(size=3))
                       for _ in range(100)]  # fmt: skip
    for e in range(1, 13):  # near a half turn (handed to pin.log6)
        axis = rng.normal(size=3)
        placements.append(pin.SE3(pin.exp3((np.pi - 10.0**-e) * axis / np.linalg.norm(axis)),
                                  rng.normal(size=3)))  # fmt: skip
    placements.append(pin.SE3(pin.exp3(np.array([np.pi, 0.0, 0.0])), np.ones(3)))
    R = np.array([M.rotation for M in placements])
    p = np.array([M.translation for M in placements])
    want = np.array([pin.log6(M).linear for M in placements])
    assert np.abs(walk_run._log6_linear(R, p).T - want).max() < 1e-12


def test_wrap_in_place_is_wrap():
    rng = np.random.default_rng(2)
    edges = [np.pi, -np.pi, 0.0, -0.0, 2 * np.pi, -2 * np.pi, 3 * np.pi, -3 * np.pi, -1e-17,
             np.nextafter(np.pi, 0.0), np.nextafter(-np.pi, 0.0), np.nextafter(-np.pi, -4.0),
             np.nextafter(3 * np.pi, 0.0), np.nextafter(-3 * np.pi, 0.0)]  # fmt: skip
    for x in (rng.uniform(-3 * np.pi, 3 * np.pi, 10**5), rng.uniform(-20.0, 20.0, 10**4),
              np.array(edges), np.array([*edges, np.nan, 40.0])):  # fmt: skip
        with np.errstate(invalid="ignore"):
            want, got = _wrap(x), _wrap_in_place(x.copy())
        assert np.array_equal(got, want, equal_nan=True)
        assert np.array_equal(np.signbit(got), np.signbit(want))


def test_range_violations_are_the_calls_in_order(male):
    """Random orientations (both or neither of a ball's Euler solutions inside its range: the
    last call's angles decide) and slowly turning ones (long chains of such states), over two
    calls (the hint carries over): the same numbers and the same hint as violation called
    state by state."""
    rng = np.random.default_rng(11)
    one, batch = JointRanges(male), JointRanges(male)
    if batch._plan is None:
        pytest.skip("the compiled kernels are not built")
    n = 1500
    Q = np.tile(male.standing_configuration(), (n, 1))
    Q[:, one.iq] += rng.normal(scale=0.5, size=(n, len(one.iq)))
    for b, (_, iq, *_) in enumerate(one.balls):
        if b % 2:
            Q[:, iq : iq + 4] = rng.normal(size=(n, 4))
            Q[:, iq : iq + 4] /= np.linalg.norm(Q[:, iq : iq + 4], axis=1, keepdims=True)
        else:
            R = pin.exp3(2.0 * rng.normal(size=3))
            for k in range(n):
                R = R @ pin.exp3(0.05 * rng.normal(size=3))
                Q[k, iq : iq + 4] = pin.Quaternion(R).coeffs()
    for part in (Q[:700], Q[700:]):
        want = np.array([one.violation(q) for q in part])
        assert np.abs(range_violations(batch, part) - want).max() < 1e-12
        assert (want > 0).mean() > 0.5
    assert np.abs(one.angles(Q[-1]) - batch.angles(Q[-1])).max() < 1e-12  # (the hint)
    plain, again = JointRanges(male, compiled=False), JointRanges(male, compiled=False)
    want = np.array([again.violation(q) for q in Q[:50]])  # (the NumPy path: state by state)
    assert np.array_equal(range_violations(plain, Q[:50]), want)


def test_com_reference_is_the_controllers(walked):
    _, monitor = walked
    ctl = monitor.ctl
    end = ctl.t_ref[-1]
    t = np.concatenate([[-1.0, 0.0, end, end + 2.0], np.linspace(-0.1, end + 0.1, 777)])
    want = np.array([ctl.com_reference(x)[0][:2] for x in t])
    assert np.array_equal(walk_run._com_reference(ctl, t), want)


def test_series_are_the_per_tick_checks(walked):
    """The batch series against the per-tick computation they replace: Pinocchio's centre of
    mass and sole placements, pin.log6 for the weld drift, the joint ranges state by state."""
    result, monitor = walked
    s, n = result.series, len(result.series["t"])
    model, ranges = monitor.sim.model, JointRanges(monitor.h)
    data = model.createData()
    wrench, anchor = monitor.wrenches(n)
    com, drift, fz, tilt, rng = (np.zeros((n, 3)), np.zeros(n), np.full((n, 2), np.nan),
                                 np.zeros(n), np.zeros(n))  # fmt: skip
    for k in range(n):
        q = monitor.q[k]
        com[k] = pin.centerOfMass(model, data, q)
        for j, c in enumerate(monitor.sim.contacts):
            M = pin.updateFramePlacement(model, data, c.sole)
            if anchor[c.side][k] >= 0:
                r = pin.log6(monitor.anchors[anchor[c.side][k]].actInv(M)).linear
                drift[k] = max(drift[k], math.sqrt(r @ r))
                fz[k, j] = (M.rotation @ wrench[c.side][k, :3])[2] / monitor.weight
        x, y = q[3], q[4]
        tilt[k] = math.degrees(math.acos(min(1.0, max(-1.0, 1.0 - 2.0 * (x * x + y * y)))))
        rng[k] = math.degrees(ranges.violation(q))
    on = np.isfinite(fz).any(axis=1)
    assert on.all()  # (a foot is always welded)
    for key, want in (("com_x", com[:, 0]), ("com_y", com[:, 1]), ("com_z", com[:, 2]),
                      ("drift", drift), ("fz_left", fz[:, 0]), ("fz_right", fz[:, 1]),
                      ("tilt", tilt), ("range", rng)):  # fmt: skip
        assert np.array_equal(np.isnan(s[key]), np.isnan(want)), key
        assert np.nanmax(np.abs(s[key] - want)) < 1e-12, key
    assert np.isfinite(s["consistency"]).sum() >= n // monitor.ctl.every


def test_kinematics_without_the_kernels_are_the_same(walked):
    _, monitor = walked
    model, Q = monitor.sim.model, monitor.q[:300]
    soles = {c.side: c.sole for c in monitor.sim.contacts}

    class Unavailable:
        available = False

    fast = walk_run._kinematics(TreeDynamics(model), model, Q, soles)
    slow = walk_run._kinematics(Unavailable(), model, Q, soles)
    assert np.abs(fast[0] - slow[0]).max() < 1e-12
    for side in soles:
        assert np.abs(fast[1][side] - slow[1][side]).max() < 1e-12
        assert np.abs(fast[2][side] - slow[2][side]).max() < 1e-12


def test_a_fall_stops_the_run_at_its_tick(male):
    """The pelvis below 80 % of its start height or the trunk tilted over 30 degrees (a NaN
    orientation too, as 180 degrees) raises at that tick, with the fall's numbers."""
    setup = walk_run.prepare(male, GaitParameters(steps=2))
    monitor = walk_run.WalkMonitor(male, setup.sim, setup.ctl)
    nv = setup.sim.model.nv
    q, zero = setup.q0.copy(), np.zeros(nv)
    monitor.observe(setup.sim, 0, 0.0, q, zero, StepResult(1e-3, q, zero, zero, None))
    z = q[2]

    def tick(k, tilt=0.0, drop=0.0, quat=None):
        qk = q.copy()
        qk[3:7] = pin.Quaternion(pin.exp3(np.array([math.radians(tilt), 0.0, 0.0]))).coeffs()
        if quat is not None:
            qk[3:7] = quat
        end = qk.copy()
        end[2] -= drop
        monitor.observe(setup.sim, k, k * 1e-3, qk, zero, StepResult(k * 1e-3, end, zero,
                                                                         zero, None))  # fmt: skip

    tick(1, tilt=29.9)
    tick(2, drop=0.19 * z)
    with pytest.raises(RunFailed, match=rf"fall at t = 0\.003 s: pelvis {z:.3f} m \(start "
                                        rf"{z:.3f} m\), trunk tilt 30\.1 deg"):  # fmt: skip
        tick(3, tilt=30.1)
    with pytest.raises(RunFailed, match=rf"t = 0\.004 s: pelvis {z - 0.21 * z:.3f} m .* 0\.0 deg"):
        tick(4, drop=0.21 * z)
    with pytest.raises(RunFailed, match=r"t = 0\.005 s: .* trunk tilt 180\.0 deg"):
        tick(5, quat=[np.nan, 0.0, 0.0, 1.0])
