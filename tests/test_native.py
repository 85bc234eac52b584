"""The native backend (the project's constraints solved in Pinocchio's C++) against the NumPy
reference KKT solve: the twins, the dense path for constraints without one, redundant sets."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model, random_state

from humanoid.constraints import Baumgarte, PointContact, Weld, constrained_dynamics
from humanoid.constraints.native import NativeSolve


class Plain(Weld):
    """A weld that does not tell Pinocchio what it is: the native backend must solve it from
    its J and drift (the path of a user's own constraint)."""

    def twin(self, model, baumgarte):
        return None


def _welds(h, q, cls=Weld, offset=None):
    m = h.model
    data = m.createData()
    pin.framesForwardKinematics(m, data, q)
    out = []
    for f in h.feet:
        fid = m.getFrameId(f)
        anchor = data.oMf[fid] if offset is None else data.oMf[fid] * offset
        out.append(cls(f, fid, anchor))
    return out


def _close(ours, ref, rel):
    return np.abs(ours - ref).max() <= rel * max(1.0, np.abs(ref).max())


@pytest.mark.parametrize("name", ["male", "human"])
@pytest.mark.parametrize("cls", [Weld, Plain])
def test_native_equals_the_reference_on_random_states(name, cls):
    """Random states, both feet welded 1 cm / 2 degrees away from their anchors (so the
    Baumgarte position terms act), gains off and on: the same accelerations and forces to
    1e-8 of their size, through the twins (constraintDynamics) and through J and drift
    (forwardDynamics)."""
    h = get_model(name, "quaternion")
    m = h.model
    rng = np.random.default_rng(31)
    offset = pin.SE3(pin.exp3(np.array([0.02, -0.03, 0.01])), np.array([0.01, -0.005, 0.008]))
    for _ in range(4):
        q, v = random_state(h, rng)
        tau = rng.normal(scale=20.0, size=h.nv)
        for baumgarte in (Baumgarte(), Baumgarte(alpha=40.0, beta=40.0)):
            constraints = _welds(h, q, cls, offset)
            ref = constrained_dynamics(m, m.createData(), q, v, tau, constraints, baumgarte)
            solve = NativeSolve(m, constraints, baumgarte)
            assert solve.native == (cls is Weld)
            a = solve.acceleration(q, v, tau).copy()
            assert _close(a, ref.a, 1e-8), np.abs(a - ref.a).max()
            assert _close(solve.forces, ref.forces, 1e-8)
        without = constrained_dynamics(m, m.createData(), q, v, tau, constraints)
        assert not _close(a, without.a, 1e-3), "the Baumgarte terms should matter here"


@pytest.mark.parametrize("cls", [PointContact, "plain"])
def test_native_solves_redundant_point_contacts(cls):
    """Four pinned corners per foot (24 rows of rank 12): the accelerations equal the
    reference's (its eigen cut-off) within 1e-6 of their size; the proximal iterations give
    forces that balance the same resultant (the split between corners is not unique)."""
    h = get_model("male", "quaternion")
    m = h.model
    data = m.createData()
    q = h.standing_configuration()
    pin.framesForwardKinematics(m, data, q)

    class PlainPoint(PointContact):
        def twin(self, model, baumgarte):
            return None

    kind = PointContact if cls is PointContact else PlainPoint
    names = h.contact_points["left"] + h.contact_points["right"]
    constraints = [kind(n, m.getFrameId(n), data.oMf[m.getFrameId(n)].translation) for n in names]
    rng = np.random.default_rng(32)
    tau = np.zeros(h.nv)
    tau[6:] = rng.normal(scale=10.0, size=h.nv - 6)
    v = np.zeros(h.nv)
    ref = constrained_dynamics(m, m.createData(), q, v, tau, constraints)
    solve = NativeSolve(m, constraints, redundant=True)
    a = solve.acceleration(q, v, tau).copy()
    assert _close(a, ref.a, 1e-6), np.abs(a - ref.a).max()
    total = solve.forces.reshape(-1, 3).sum(axis=0)
    assert total == pytest.approx(ref.forces.reshape(-1, 3).sum(axis=0), rel=1e-6, abs=1e-6)


def test_the_former_pinocchio_backend_is_named_in_the_error():
    from humanoid.errors import SceneError
    from humanoid.scene import Scene, Stabilisation

    with pytest.raises(SceneError, match="'pinocchio' is now 'native'"):
        Scene(stabilisation=Stabilisation(backend="pinocchio"))
