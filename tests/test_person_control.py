"""The person's walk's sampled controller: its QP every ``CONTROL_PERIOD`` (4 ms) and at once
whenever a foot starts or stops carrying load or a loaded point slides; between ticks, the
torques of the solve's accelerations and contact forces at the state now."""

import numpy as np
import pytest
from conftest import get_model

from humanoid.errors import WalkError
from humanoid.optimal.cycle import stored_gait
from humanoid.walking.person import (
    CONTROL_PERIOD,
    OFF_COURSE,
    SLIDING,
    CycleTracker,
    control_steps,
    walk_cycle,
)


def test_the_qp_runs_every_period_and_when_a_foot_lands_lifts_slides_or_strays(monkeypatch):
    """Two heel strikes of the male body: a solve at every 4th step, at every step where the
    set of feet the plant's ground pushes up changed since the last solve (the landing foot's
    heel strike, the other's toe off), and at no other step but where a velocity left the
    held accelerations' course by ``OFF_COURSE`` or a loaded point slides (faster than
    ``SLIDING``, its speed read here from a forward kinematics of its own). At a tick the held
    torques are the QP's own; the walk records its period and its solves."""
    import pinocchio as pin

    h = get_model("male", "quaternion")
    gait = stored_gait(h)
    data = h.model.createData()
    every = int(round(CONTROL_PERIOD / 1e-3))
    why: dict[int, str] = {}  # the solves by step: tick, change, slide
    gap: list[float] = []  # |held torques - the QP's| at its ticks, over |the QP's|
    before = CycleTracker.before_step

    def spy(self, sim, k, t, q, v):
        held, found = self.sampled, sim.ground_step
        n, last = held.solves, held.solved_with
        off = k % every != 0 and held.off_course(v, 1e-3)
        if off:  # by hand: the velocities against the held accelerations' from the tick
            v0, dv = held._course
            assert np.abs(v - v0 - (held.held_for + 1) * 1e-3 * dv).max() > OFF_COURSE
        before(self, sim, k, t, q, v)
        if held.solves == n:
            return
        if k % every == 0:
            why[k] = "tick"
        elif held.loaded_feet(found) != last:
            why[k] = "change"
        elif off:
            why[k] = "off course"
        else:
            pin.forwardKinematics(h.model, data, q, v)
            pushed = found.impulses[:, 2] > 0.0
            speed = [
                np.linalg.norm(data.v[int(j)].linear + np.cross(data.v[int(j)].angular, r))
                for j, r in zip(found.joints[pushed], found.local[pushed], strict=True)
            ]
            why[k] = "slide" if max(speed) > SLIDING else "none"
        gap.append(np.abs(held.torques(q, v) - self.tau).max() / np.abs(self.tau).max())

    monkeypatch.setattr(CycleTracker, "before_step", spy)
    w = walk_cycle(h, gait, 2)
    assert w.completed
    steps = len(w.record.t)
    meta = w.trajectory.metadata
    assert meta["control_period"] == pytest.approx(CONTROL_PERIOD)
    assert meta["qp_solves"] == len(why)
    assert "none" not in why.values(), why
    # the changes replayed from the record: before step k the plant's last ground step is
    # step k - 1's (row k - 1: a side with a point pushed up)
    loaded = [frozenset(s for s in ("left", "right") if w.record.force[s][k, 2] > 0.0)
              for k in range(steps)]  # fmt: skip
    last = None
    for k in range(steps):
        now = loaded[k - 1] if k else frozenset()
        if k % every == 0 or now != last:
            assert k in why, k
        if k in why:
            last = now
    changes = [k for k, r in why.items() if r == "change"]
    assert 2 <= len(changes) <= 12, changes
    assert len(why) < 0.6 * steps  # held between most steps
    assert max(gap) < 1e-9, max(gap)
    assert np.abs(w.trajectory.tau[:, :6]).max() == 0.0


def test_the_period_is_a_whole_number_of_steps():
    assert control_steps(None, 1e-3) == 4
    assert control_steps(None, 5e-3) == 1  # a step longer than the period: every step
    assert control_steps(2e-3, 1e-3) == 2
    assert control_steps(1e-3, 1e-3) == 1
    for bad in (2.5e-3, 0.0, -1e-3, 5e-4, float("nan")):
        with pytest.raises(WalkError, match="control_dt must be a whole number of steps"):
            control_steps(bad, 1e-3)


def test_every_step_solves_at_every_step():
    """``control_dt`` = dt: a solve per step, as before the sampled controller."""
    h = get_model("male", "quaternion")
    w = walk_cycle(h, stored_gait(h), 1, control_dt=1e-3)
    assert w.completed
    assert w.trajectory.metadata["qp_solves"] == len(w.record.t)


def test_a_velocity_off_the_held_course_asks_for_the_qp():
    """:meth:`Sampled.off_course`: the step after a tick expects v + dt dv, and k steps on
    v + (k + 1) dt dv; a velocity ``OFF_COURSE`` or more from it is off course."""
    from humanoid.walking.person import Sampled

    h = get_model("male", "quaternion")
    model = h.model
    rng = np.random.default_rng(5)
    v0, dv, dt = rng.normal(size=model.nv), rng.normal(size=model.nv), 1e-3
    held = Sampled(model, {})
    held.hold(v0, dv, [], np.zeros((0, 3)), np.zeros((0, 3)), model.createData())
    assert not held.off_course(v0 + dt * dv, dt)
    nudge = np.zeros(model.nv)
    nudge[17] = 1.01 * OFF_COURSE
    assert held.off_course(v0 + dt * dv + nudge, dt)
    assert not held.off_course(v0 + dt * dv + 0.99 * nudge / 1.01, dt)
    held.held_for = 3
    assert not held.off_course(v0 + 4 * dt * dv, dt)
    assert held.off_course(v0 + dt * dv, dt) == (np.abs(3 * dt * dv).max() > OFF_COURSE)


def _references():
    """The male body's shipped cycle as the tracker reads it: straight, on the 2 m circle, and
    from standing through two strides to a stop."""
    from humanoid.optimal.cycle import stored_transition, stored_turn
    from humanoid.walking.person import CycleReference

    h = get_model("male", "quaternion")
    gait = stored_gait(h)
    through = CycleReference.through(gait, stored_transition(gait, "start"),
                                     stored_transition(gait, "stop"), 2)  # fmt: skip
    return h, [CycleReference(gait), CycleReference(stored_turn(gait, 2.0)), through]


def test_the_tabulated_reference_is_the_cycles_state():
    """CycleReference.tabulated against state: the same numbers at the table's times (the
    nodes and every millisecond between, over later laps too), close between them, and the
    whole motion's ends held beyond them."""
    import pinocchio as pin

    h, refs = _references()
    rng = np.random.default_rng(31)
    for ref in refs:
        times = ref._table()[1]
        laps = (0, 1, 3) if ref.periodic else (0,)
        for t in [*rng.choice(times, 40), *(times[-1] + ref.period * np.array(laps[1:]))]:
            for lap in laps:
                s = float(t) + lap * ref.period
                (q, v, a), (q0, v0, a0) = ref.tabulated(s), ref.state(s)
                # (a lap's turned quaternion may be the other of the rotation's two)
                assert np.abs(pin.difference(h.model, q0, q)).max() < 1e-9
                np.testing.assert_allclose(v, v0, rtol=0, atol=1e-9)
                np.testing.assert_allclose(a, a0, rtol=0, atol=1e-9)
        span = 3 * ref.period if ref.periodic else ref.period + 0.1
        for t in rng.uniform(-0.05, span, 200):
            q, v, a = ref.tabulated(t)
            q0, v0, a0 = ref.state(t)
            assert np.abs(pin.difference(h.model, q0, q)).max() < 1e-4
            assert np.abs(v - v0).max() < 3e-4
            assert np.abs(a - a0).max() < 10.0


def test_the_lift_times_are_the_contact_sets_scanned():
    """time_to_lift from its table per point: the first later interval whose contact set
    leaves the point out (inf if none within a stride, or before the motion ends)."""
    import math

    _, refs = _references()
    rng = np.random.default_rng(32)
    for ref in refs:
        n = len(ref.sets)
        for t in rng.uniform(-0.05, 2.5 * ref.period, 100):
            lap, k, _ = ref._interval(t)
            for p in sorted(ref.forces):
                want = math.inf
                for j in range(n if ref.periodic else n - k):
                    if p not in ref.sets[(k + j) % n]:
                        lapj, kj = divmod(k + j, n)
                        want = (lap + lapj) * ref.period + ref.t[kj] - t
                        break
                assert ref.time_to_lift(t, p) == want
