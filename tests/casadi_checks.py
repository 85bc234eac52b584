"""Run by tests/test_optimal_dynamics.py in a process of its own (OpenSim's bundled casadi).

The symbolic model (casadi expressions) against Pinocchio, on every joint type the toolkit
loads: RNEA, the mass matrix (CRBA), integration on the Lie group, frame placements,
velocities and classical accelerations, point forces, and the derivatives IPOPT is given.

Tolerance: 1e-10 relative to the larger of 1 and the largest entry compared.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model

from humanoid.errors import ModelError
from humanoid.optimal import SymbolicModel

TOL = 1e-10


def _close(x, ref, tol=TOL):
    x, ref = np.asarray(x, dtype=float).reshape(np.shape(ref)), np.asarray(ref)
    scale = max(1.0, float(np.abs(ref).max(initial=0.0)))
    err = float(np.abs(x - ref).max(initial=0.0))
    assert err <= tol * scale, f"error {err:.3g} against scale {scale:.3g}"


def _every_joint_model() -> pin.Model:
    """A tree with one joint of each supported type, random placements and inertias."""
    rng = np.random.default_rng(7)
    model = pin.Model()

    def unit(n=3):
        a = rng.normal(size=n)
        return a / np.linalg.norm(a)

    joints = [
        pin.JointModelFreeFlyer(),
        pin.JointModelSpherical(),
        pin.JointModelRX(),
        pin.JointModelRY(),
        pin.JointModelRZ(),
        pin.JointModelRevoluteUnaligned(unit()),
        pin.JointModelRUBX(),
        pin.JointModelRUBY(),
        pin.JointModelRUBZ(),
        _continuous_joint(unit()),
        pin.JointModelPX(),
        pin.JointModelPY(),
        pin.JointModelPZ(),
        pin.JointModelPrismaticUnaligned(unit()),
        pin.JointModelTranslation(),
    ]
    parent = 0
    for i, jm in enumerate(joints):
        # a branch every third joint, so that forces meet at a parent from two children
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3) * 0.2)
        jid = model.addJoint(parent if i % 3 else max(parent - 1, 0), jm, placement, f"j{i}")
        inertia = pin.Inertia(
            rng.uniform(0.5, 3.0), rng.normal(size=3) * 0.1, np.diag(rng.uniform(0.01, 0.1, 3))
        )
        model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
        model.addFrame(
            pin.Frame(
                f"f{i}",
                jid,
                pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3) * 0.1),
                pin.FrameType.OP_FRAME,
            )
        )
        parent = jid
    return model


def _continuous_joint(axis) -> pin.JointModel:
    """A continuous URDF joint on an unaligned axis, as the URDF parser builds it (the bindings
    cannot give a RevoluteUnboundedUnaligned its axis)."""
    x, y, z = axis
    urdf = (
        '<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="continuous">'
        f'<parent link="a"/><child link="b"/><axis xyz="{x} {y} {z}"/></joint></robot>'
    )
    jm = pin.buildModelFromXML(urdf).joints[1]
    assert jm.shortname() == "JointModelRevoluteUnboundedUnaligned"
    return jm


MODELS = {
    "every_joint": _every_joint_model,
    "male": lambda: get_model("male", "quaternion").model,
    "talos": lambda: get_model("talos", "quaternion").model,
}


@pytest.fixture(scope="module", params=sorted(MODELS))
def case(request):
    model = MODELS[request.param]()
    sm = SymbolicModel(model)
    frames = [f.name for f in model.frames if f.type == pin.FrameType.OP_FRAME][:12]
    if not frames:
        frames = [model.frames[-1].name]
    q, v, a = (ca.SX.sym(s, n) for s, n in (("q", model.nq), ("v", model.nv), ("a", model.nv)))
    kin = sm.kinematics(q, v, a)
    outs = {
        "tau": sm.rnea(q, v, a),
        "M": sm.mass_matrix(q),
        "next": sm.integrate(q, v),
        "pos": ca.vertcat(*[sm.frame_placement(kin, f)[1] for f in frames]),
        "rot": ca.vertcat(*[sm.frame_placement(kin, f)[0] for f in frames]),
        "vel": ca.vertcat(*[sm.frame_velocity(kin, f) for f in frames]),
        "acc": ca.vertcat(*[sm.frame_acceleration(kin, f) for f in frames]),
    }
    fn = ca.Function("all", [q, v, a], list(outs.values()), ["q", "v", "a"], list(outs))
    return request.param, model, sm, frames, fn


def _states(model, n=4, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        yield q, rng.normal(size=model.nv) * 2.0, rng.normal(size=model.nv) * 3.0


def test_rnea_mass_matrix_and_integration_equal_pinocchio(case):
    _, model, _, _, fn = case
    data = model.createData()
    for q, v, a in _states(model):
        out = fn(q=q, v=v, a=a)
        _close(out["tau"], pin.rnea(model, data, q, v, a))
        M = pin.crba(model, data, q)
        _close(out["M"], np.triu(M) + np.triu(M, 1).T)
        _close(out["next"], pin.integrate(model, q, v))
        # the Taylor branch of the exponential maps: a velocity of 1e-5 rad/s
        _close(fn(q=q, v=v * 1e-5, a=a)["next"], pin.integrate(model, q, v * 1e-5))


def test_frame_kinematics_equal_pinocchio(case):
    _, model, _, frames, fn = case
    data = model.createData()
    lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    for q, v, a in _states(model, seed=1):
        out = fn(q=q, v=v, a=a)
        pin.forwardKinematics(model, data, q, v, a)
        pin.updateFramePlacements(model, data)
        ids = [model.getFrameId(f) for f in frames]
        _close(out["pos"], np.concatenate([data.oMf[i].translation for i in ids]))
        _close(out["rot"], np.vstack([data.oMf[i].rotation for i in ids]))
        _close(
            out["vel"],
            np.concatenate([pin.getFrameVelocity(model, data, i, lwa).vector for i in ids]),
        )
        _close(
            out["acc"],
            np.concatenate(
                [pin.getFrameClassicalAcceleration(model, data, i, lwa).linear for i in ids]
            ),
        )


def test_point_forces_enter_as_jacobian_transposes(case):
    """RNEA with forces at frames = RNEA - sum_p J_p^T f_p (J_p the frame origin's linear
    Jacobian in world axes): the contact forces of the collocation's dynamics."""
    _, model, sm, frames, _ = case
    data = model.createData()
    q, v, a = next(_states(model, seed=2))
    rng = np.random.default_rng(3)
    forces = {f: rng.normal(size=3) * 100.0 for f in frames[:4]}
    expr = sm.rnea(ca.DM(q), ca.DM(v), ca.DM(a), [(f, ca.DM(x)) for f, x in forces.items()])
    ref = pin.rnea(model, data, q, v, a)
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    for f, x in forces.items():
        J = pin.getFrameJacobian(
            model, data, model.getFrameId(f), pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )
        ref -= J[:3].T @ x
    _close(ca.evalf(expr), ref)


def test_derivatives_equal_pinocchio_analytical_derivatives(case):
    """d tau / d q (on the manifold: through q (+) dq at dq = 0), d tau / d v and
    d tau / d a from casadi's differentiation equal computeRNEADerivatives."""
    _, model, sm, _, _ = case
    q, v, a = (ca.SX.sym(s, n) for s, n in (("q", model.nq), ("v", model.nv), ("a", model.nv)))
    dq = ca.SX.sym("dq", model.nv)
    tau = sm.rnea(sm.integrate(q, dq), v, a)
    jac = ca.Function(
        "derivatives",
        [q, v, a, dq],
        [ca.jacobian(tau, dq), ca.jacobian(tau, v), ca.jacobian(tau, a)],
    )
    data = model.createData()
    for q0, v0, a0 in _states(model, n=2, seed=4):
        dq_, dv_, da_ = (np.array(x) for x in jac(q0, v0, a0, np.zeros(model.nv)))
        ref_q, ref_v, ref_a = pin.computeRNEADerivatives(model, data, q0, v0, a0)
        ref_a = np.triu(ref_a) + np.triu(ref_a, 1).T
        for x, ref in ((dq_, ref_q), (dv_, ref_v), (da_, ref_a)):
            _close(x, ref, 1e-9)


def test_an_unsupported_joint_is_a_model_error_naming_it():
    model = pin.Model()
    model.addJoint(0, pin.JointModelPlanar(), pin.SE3.Identity(), "slider")
    with pytest.raises(ModelError, match="'slider' is a JointModelPlanar"):
        SymbolicModel(model)


def test_an_unknown_frame_is_a_model_error():
    sm = SymbolicModel(_every_joint_model())
    with pytest.raises(ModelError, match="no frame 'nowhere'"):
        sm.frame("nowhere")


def test_the_optimal_package_names_its_modules():
    """``humanoid.optimal.x`` is the module (tests/test_layout.py skips this package)."""
    import types

    import humanoid.optimal as optimal

    assert isinstance(optimal.dynamics, types.ModuleType)
