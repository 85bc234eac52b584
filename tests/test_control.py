"""The control layer (humanoid.control): every task's rows against Pinocchio's own kinematics,
its PD law converging (the sign of every error), and the whole-body QP's constraints."""

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model, random_state

from humanoid.control import (
    CentreOfMassTask,
    ForceTask,
    FrameTask,
    MomentumTask,
    OrientationTask,
    PostureTask,
    TaskStack,
    WarmQP,
    dynamics_terms,
    whole_body_qp,
)
from humanoid.control.qp import frame_jacobians, ramped_bound
from humanoid.errors import HumanoidError

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
TOL = 1e-9


@pytest.fixture(scope="module")
def state():
    """The male body at a random state, its pelvis rotated and moving (seeded)."""
    h = get_model("male", "quaternion")
    q, v = random_state(h, np.random.default_rng(3))
    data = h.model.createData()
    dynamics_terms(h.model, data, q, v)
    return h, data, q, v


def _reached(h, task, q, v):
    """The smallest dv with J dv = a for ``task`` alone, and the data at (q, v, dv)."""
    model = h.model
    data = model.createData()
    dynamics_terms(model, data, q, v)
    J, a = task.compute(model, data, q, v)
    dv = np.linalg.lstsq(J, a, rcond=None)[0]
    assert np.allclose(J @ dv, a, atol=TOL)  # (every task here has full row rank)
    out = model.createData()
    pin.forwardKinematics(model, out, q, v, dv)
    pin.updateFramePlacements(model, out)
    return dv, out


def test_a_frame_task_without_feedback_gives_the_frame_its_reference_acceleration(state):
    h, _, q, v = state
    fid = h.sole_id("left")
    a_ref = np.array([0.3, -1.2, 2.0, 4.0, -0.5, 1.5])
    task = FrameTask(fid, pin.SE3.Identity(), 0.0, 0.0, 1.0, np.zeros(6), a_ref)
    _, out = _reached(h, task, q, v)
    got = pin.getFrameClassicalAcceleration(h.model, out, fid, LWA).vector
    assert np.abs(got - a_ref).max() < TOL


def test_a_frame_tasks_orientation_error_is_in_world_axes(state):
    """At rest, a reference turned by w (world axes) from the frame's orientation asks the
    angular acceleration kp w, in world axes (a planted error log3(R^T R_ref), the frame's
    own axes, used as world, passed the tests whose frames were level or that converged)."""
    h, _, q, _ = state
    model = h.model
    data = model.createData()
    v = np.zeros(model.nv)
    dynamics_terms(model, data, q, v)
    fid = h.sole_id("left")
    M = data.oMf[fid]
    assert np.abs(M.rotation - np.eye(3)).max() > 0.1  # the sole is turned
    w = np.array([0.1, -0.2, 0.15])
    target = pin.SE3(pin.exp3(w) @ M.rotation, M.translation.copy())
    kp = 25.0
    _, a = FrameTask(fid, target, kp, 0.0, 1.0).compute(model, data, q, v)
    np.testing.assert_allclose(a[3:], kp * w, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a[:3], 0.0, rtol=0, atol=1e-9)


def test_a_frame_tasks_local_angular_rows_are_pinocchios_local_jacobian(state):
    h, data, q, v = state
    fid = h.sole_id("right")
    task = FrameTask(fid, pin.SE3.Identity(), 1.0, 1.0, 1.0, local_angular=True)
    J, _ = task.compute(h.model, data, q, v)
    local = pin.getFrameJacobian(h.model, data, fid, pin.ReferenceFrame.LOCAL)
    assert np.abs(J[3:] - local[3:]).max() < TOL
    assert np.abs(J[:3] - pin.getFrameJacobian(h.model, data, fid, LWA)[:3]).max() < TOL


def test_an_orientation_task_gives_the_frames_angular_acceleration(state):
    h, _, q, v = state
    fid = h.sole_id("right")  # at the end of a moving chain: its drift J'v is not zero
    dw = np.array([1.0, -2.0, 0.5])
    task = OrientationTask(fid, np.eye(3), 0.0, 0.0, 1.0, np.zeros(3), dw)
    _, out = _reached(h, task, q, v)
    assert np.abs(pin.getFrameAcceleration(h.model, out, fid, LWA).angular - dw).max() < TOL


def test_a_centre_of_mass_task_gives_the_centre_of_mass_its_acceleration(state):
    h, _, q, v = state
    ddc = np.array([0.4, -0.3, 1.1])
    task = CentreOfMassTask(np.zeros(3), np.zeros(3), ddc, 0.0, 0.0, 1.0)
    dv, _ = _reached(h, task, q, v)
    data = h.model.createData()
    pin.centerOfMass(h.model, data, q, v, dv)
    assert np.abs(data.acom[0] - ddc).max() < TOL
    assert np.allclose(task.c, data.com[0]) and np.allclose(task.dc, data.vcom[0])


def test_a_momentum_task_damps_the_centroidal_angular_momentum_at_its_rate(state):
    h, _, q, v = state
    kd, k_ref = 7.0, np.array([0.5, -1.0, 2.0])
    dv, _ = _reached(h, MomentumTask(kd, 1.0, k_ref), q, v)
    data = h.model.createData()
    k = pin.computeCentroidalMomentum(h.model, data, q, v).angular.copy()
    dk = pin.computeCentroidalMomentumTimeVariation(h.model, data, q, v, dv).angular
    assert np.abs(dk - kd * (k_ref - k)).max() < 1e-8 * max(1.0, np.abs(dk).max())


def test_a_posture_task_sets_the_joints_or_the_roots_acceleration(state):
    h, data, q, v = state
    nv = h.model.nv
    rng = np.random.default_rng(4)
    q_ref, v_ref, a_ref = pin.integrate(h.model, q, rng.normal(size=nv) * 0.1), v * 0.5, v * 2
    for dofs, rows in (("joints", slice(6, None)), ("root", slice(0, 6))):
        J, a = PostureTask(q_ref, 3.0, 2.0, 1.0, v_ref, a_ref, dofs).compute(h.model, data, q, v)
        e = pin.difference(h.model, q, q_ref)
        assert np.array_equal(J, np.eye(nv)[rows])
        assert np.allclose(a, a_ref[rows] + 3.0 * e[rows] + 2.0 * (v_ref - v)[rows], atol=TOL)
    with pytest.raises(HumanoidError, match="dofs must be one of"):
        PostureTask(q_ref, 1.0, 1.0, 1.0, dofs="arms")


def _converge(h, make, error, seconds=3.0, dt=2e-3):
    """Kinematic integration of dv = the smallest solution of ``make(q, v)``'s rows from the
    standing pose, moving and tilted: the task's error [m or rad] at the start and the end."""
    model = h.model
    data = model.createData()
    q = h.standing_configuration()
    q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.3, -0.2, 0.5)).coeffs()
    v = np.zeros(model.nv)
    v[:6] = [0.2, -0.1, 0.1, 0.5, -0.3, 0.2]
    first = None
    for _ in range(int(seconds / dt)):
        dynamics_terms(model, data, q, v)
        e = error(data, q)
        first = e if first is None else first
        stack = TaskStack(model, data, q, v)
        stack.add(make(q, v))
        J, a, _ = stack.stacked()
        dv = np.linalg.lstsq(J, a, rcond=None)[0]
        v = v + dt * dv
        q = pin.integrate(model, q, dt * v)
    dynamics_terms(model, data, q, v)
    return first, error(data, q)


@pytest.mark.parametrize("kind", ["frame", "orientation", "centre_of_mass"])
def test_every_tasks_feedback_drives_its_error_to_zero(kind):
    """The PD laws' signs: each task alone, from a tilted, moving body, reaches its target
    (kp 25, kd 10: critically damped; 3 s is 15 time constants)."""
    h = get_model("male", "quaternion")
    model = h.model
    fid = h.sole_id("left")
    pelvis = model.getFrameId(model.names[1], pin.FrameType.JOINT)
    target = pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, -0.3), np.array([0.2, 0.1, 0.3]))
    c_target = np.array([0.1, -0.05, 0.8])
    if kind == "frame":
        first, last = _converge(
            h, lambda q, v: FrameTask(fid, target, 25.0, 10.0, 1.0),
            lambda d, q: np.linalg.norm(pin.log6(d.oMf[fid].actInv(target)).vector))  # fmt: skip
    elif kind == "orientation":
        first, last = _converge(
            h,
            lambda q, v: OrientationTask(pelvis, target.rotation, 25.0, 10.0, 1.0),
            lambda d, q: np.linalg.norm(pin.log3(d.oMf[pelvis].rotation.T @ target.rotation)),
        )
    else:
        first, last = _converge(
            h,
            lambda q, v: CentreOfMassTask(c_target, np.zeros(3), np.zeros(3), 25.0, 10.0, 1.0),
            lambda d, q: np.linalg.norm(pin.centerOfMass(h.model, d, q) - c_target),
        )
    assert first > 0.05 and last < 1e-3 * first, (first, last)


def test_a_tilt_only_orientation_task_leaves_the_yaw_free(state):
    h, data, q, v = state
    pelvis = h.model.getFrameId(h.model.names[1], pin.FrameType.JOINT)
    R = data.oMf[pelvis].rotation
    yaw = np.arctan2(R[1, 0], R[0, 0])
    tilt = OrientationTask(pelvis, None, 9.0, 0.0, 1.0, tilt_only=True)
    level = OrientationTask(pelvis, pin.utils.rotate("z", yaw), 9.0, 0.0, 1.0)
    assert np.allclose(tilt.compute(h.model, data, q, v)[1], level.compute(h.model, data, q, v)[1])


def test_a_force_task_is_its_weight_times_the_squared_residual():
    rng = np.random.default_rng(5)
    S, target, f = rng.normal(size=(2, 9)), rng.normal(size=2), rng.normal(size=9)
    P, qf = ForceTask(target, 3.0, S).terms(9)
    cost = 0.5 * f @ P @ f + qf @ f + 1.5 * target @ target
    assert cost == pytest.approx(1.5 * np.sum((S @ f - target) ** 2), rel=1e-12)
    P, qf = ForceTask(0.25, 2.0).terms(3)
    assert np.allclose(P, 2.0 * np.eye(3)) and np.allclose(qf, -0.5)


def test_a_ramped_bound_falls_to_the_planned_force_when_the_point_lifts():
    assert ramped_bound(0.3, 1.0, 0.05, 0.2) == pytest.approx(0.5)
    assert ramped_bound(0.3, 0.025, 0.05, 0.2) == pytest.approx(0.4)
    assert ramped_bound(0.3, 0.0, 0.05, 0.2) == pytest.approx(0.3)
    assert ramped_bound(0.3, -0.01, 0.05, 0.2) == pytest.approx(0.3)


def test_the_whole_body_qp_keeps_its_constraints_and_its_torques_leave_the_root_alone():
    """The male body standing on its soles' points: the free flyer's rows of the dynamics hold
    with the solved forces, the forces stay in their pyramids and under their bounds (one
    point's at zero), the sticking rows hold, and tau = M dv + h - Jc' f has a zero root."""
    h = get_model("male", "quaternion")
    model = h.model
    data = model.createData()
    q = h.standing_configuration()
    q[3:7] = pin.Quaternion(pin.utils.rotate("z", 0.7)).coeffs()  # a rotated pelvis
    v = np.zeros(model.nv)
    M, hvec = dynamics_terms(model, data, q, v)
    weight = h.mass * 9.81
    points = [h.frame_id(n) for s in ("left", "right") for n in h.require_contact_points(s)]
    Jc = frame_jacobians(model, data, points)
    tasks = TaskStack(model, data, q, v)
    tasks.add(CentreOfMassTask(pin.centerOfMass(model, data, q), np.zeros(3),
                               np.array([0.3, 0.0, 0.0]), 0.0, 0.0, 1.0))  # fmt: skip
    tasks.add(PostureTask(q, 10.0, 5.0, 1e-2))
    k = len(points)
    upper = np.full(k, 10.0)
    upper[0] = 0.0
    mu = 0.6
    p = whole_body_qp(M, hvec, weight, tasks, Jc, mu, forces=[ForceTask(0.0, 1e-3)],
                      motion=[(Jc, np.zeros(3 * k))], upper=upper)  # fmt: skip
    x, relaxed = p.solve(WarmQP(eps_abs=1e-10, max_iter=1000, primal=1e-8, dual=1e-6))
    assert x is not None and not relaxed
    tau, dv, f = p.torques(x, M, hvec, weight)
    assert np.abs(M[:6] @ dv + hvec[:6] - Jc.T[:6] @ f.ravel()).max() < 1e-6 * weight
    assert np.abs(Jc @ dv).max() < 1e-6
    assert np.all(f[:, 2] >= -1e-6 * weight) and f[0, 2] < 1e-6 * weight
    assert np.all(np.abs(f[:, :2]) <= mu / np.sqrt(2) * f[:, 2:] + 1e-6 * weight)
    assert np.all(f[:, 2] <= upper * weight + 1e-6 * weight)
    full = M @ dv + hvec - Jc.T @ f.ravel()
    assert np.abs(tau[:6]).max() == 0.0 and np.allclose(tau[6:], full[6:])
    # the forces carry the weight and push the centre of mass forward at 0.3 m/s^2
    assert f[:, 2].sum() == pytest.approx(weight, rel=0.05)
    assert f[:, 0].sum() == pytest.approx(h.mass * 0.3, rel=0.05)


def test_a_supported_centre_of_mass_task_asks_only_what_its_support_can_carry():
    """Asked to accelerate forward at 3 m/s^2 over a 10 cm square around it, the centre of mass
    gets the acceleration whose centre of pressure is the square's back edge:
    c'' = (c - p) g / z (the pressure centre behind the centre of mass pushes it forward)."""
    h = get_model("male", "quaternion")
    model = h.model
    data = model.createData()
    q, v = h.standing_configuration(), np.zeros(model.nv)
    dynamics_terms(model, data, q, v)
    c = pin.centerOfMass(model, data, q).copy()
    square = c[:2] + np.array([[-0.05, -0.05], [0.05, -0.05], [0.05, 0.05], [-0.05, 0.05]])
    task = CentreOfMassTask(c, np.zeros(3), np.array([3.0, 0.0, 0.0]), 0.0, 0.0, 1.0, square)
    _, a = task.compute(model, data, q, v)  # (at rest the drift is zero)
    g = float(np.linalg.norm(model.gravity.linear))
    assert a == pytest.approx([0.05 * g / c[2], 0.0, 0.0], abs=1e-9)
    inside = CentreOfMassTask(c, np.zeros(3), np.array([0.1, 0.0, 0.0]), 0.0, 0.0, 1.0, square)
    assert inside.compute(model, data, q, v)[1] == pytest.approx([0.1, 0.0, 0.0], abs=1e-12)


def test_the_friction_pyramid_is_inscribed_in_the_cone():
    """|f_x|, |f_y| <= (mu / sqrt 2) f_z: a force on the pyramid's edge passes, one a little
    beyond it (inside the cone) does not."""
    from humanoid.control.qp import pyramid_rows

    mu = 0.6
    G = pyramid_rows(mu, 2, 7, 1)
    edge = mu / np.sqrt(2.0)
    ok = np.array([9.0, edge, -edge, 1.0, 0.0, 0.0, 2.0])
    assert np.all(G @ ok <= 1e-15)
    beyond = ok.copy()
    beyond[4] = 1.01 * edge * 2.0  # the second point's f_x, still inside the cone mu f_z
    assert np.any(G @ beyond > 0) and np.hypot(beyond[4], beyond[5]) < mu * beyond[6]
    lifting = ok.copy()
    lifting[3] = -1e-3
    assert np.any(G @ lifting > 0)


def test_no_task_disturbs_what_the_next_one_reads(state):
    """Tasks are evaluated one after the other on one data: each leaves the kinematics the
    others read (placements, velocities, drift accelerations, Jacobians) as it found them."""
    h, _, q, v = state
    model = h.model
    data = model.createData()
    dynamics_terms(model, data, q, v)
    fid = h.sole_id("left")
    probe = FrameTask(fid, pin.SE3.Identity(), 3.0, 2.0, 1.0)
    before = probe.compute(model, data, q, v)
    pelvis = model.getFrameId(model.names[1], pin.FrameType.JOINT)
    for task in (
        MomentumTask(5.0, 1.0),
        CentreOfMassTask(np.zeros(3), np.zeros(3), np.zeros(3), 1.0, 1.0, 1.0),
        OrientationTask(pelvis, np.eye(3), 1.0, 1.0, 1.0, tilt_only=True),
        PostureTask(h.standing_configuration(), 1.0, 1.0, 1.0),
    ):
        task.compute(model, data, q, v)
        after = probe.compute(model, data, q, v)
        assert np.array_equal(after[0], before[0]) and np.array_equal(after[1], before[1]), task


def test_a_qp_without_solution_fails_the_run_with_a_typed_error_naming_when_and_why():
    from humanoid.control.qp import checked
    from humanoid.errors import RunFailed

    solver = WarmQP(eps_abs=1e-9, max_iter=10, primal=1e-7, dual=1e-4)
    solver.why = "PROXQP_MAX_ITER_REACHED: primal 1.0e-02, dual 3.0e+00"
    with pytest.raises(RunFailed, match=r"walking QP has no solution at t = 1\.250 s \(PROXQP_MAX"):
        checked(None, "walking", 1.25, solver)
    with pytest.raises(RunFailed, match="not finite"):
        checked(np.array([0.0, np.nan]), "tracking", 0.0, solver)
    x = np.ones(3)
    assert checked(x, "walking", 0.0, solver) is x


def test_the_cached_pyramids_and_the_identity_force_task_are_the_products():
    """pyramid_rows is built once per shape and an identity ForceTask skips its products by
    I: the same numbers as the loop and the products (the walks' QPs do not move)."""
    from humanoid.control.qp import pyramid_rows
    from humanoid.control.tasks import ForceTask

    for mu, k, n, off in ((0.6, 8, 65, 41), (0.45, 3, 50, 41), (0.8, 0, 41, 41)):
        m = mu / np.sqrt(2.0)
        pyramid = np.array([[0, 0, -1.0], [1, 0, -m], [-1, 0, -m], [0, 1, -m], [0, -1, -m]])
        want = np.zeros((5 * k, n))
        for i in range(k):
            want[5 * i : 5 * i + 5, off + 3 * i : off + 3 * i + 3] = pyramid
        got = pyramid_rows(mu, k, n, off)
        assert np.array_equal(got, want)
        got[:] = 1.0  # a copy: the cached one is not the caller's
        assert np.array_equal(pyramid_rows(mu, k, n, off), want)
    rng = np.random.default_rng(7)
    target, S = rng.normal(size=24), np.eye(24)
    P, q = ForceTask(target, 0.01).terms(24)
    assert np.array_equal(P, 0.01 * S.T @ S) and np.array_equal(q, -0.01 * S.T @ target)


def test_point_drifts_are_pinocchios_classical_accelerations_at_zero_dv():
    """point_drifts (J' v of points on joints, world axes) against Pinocchio's classical
    acceleration of a frame placed at each point, at a random state with a rotated, moving
    pelvis and dv = 0."""
    from humanoid.control.qp import point_drifts

    h = get_model("male", "quaternion")
    model = h.model.copy()
    rng = np.random.default_rng(11)
    q, v = random_state(h, rng)
    joints = [3, 3, 7, 12, 12, 12]
    local = rng.normal(size=(len(joints), 3)) * 0.1
    frames = [model.addFrame(pin.Frame(f"p{i}", j, 0, pin.SE3(np.eye(3), r),
                                       pin.FrameType.OP_FRAME))
              for i, (j, r) in enumerate(zip(joints, local, strict=True))]  # fmt: skip
    data = model.createData()
    dynamics_terms(model, data, q, v)
    want = np.array([pin.getFrameClassicalAcceleration(model, data, f, LWA).linear
                     for f in frames])  # fmt: skip
    got = point_drifts(data, joints, local)
    assert np.abs(got).max() > 1.0  # a real drift at this state
    np.testing.assert_allclose(got, want, atol=1e-12 * np.abs(want).max())


def test_the_sticking_rows_span_the_loaded_points_rows():
    """row_space gives an orthonormal basis of a foot's twelve dependent rows' span (rank 6):
    the same projector as the SVD's, so U^T J dv = U^T b is the least-squares-consistent
    set of J dv = b."""
    from humanoid.control.qp import row_space

    h = get_model("male", "quaternion")
    model = h.model
    rng = np.random.default_rng(13)
    q, v = random_state(h, rng)
    data = model.createData()
    dynamics_terms(model, data, q, v)
    foot = model.frames[h.sole_id("right")].parentJoint
    J6 = pin.getJointJacobian(model, data, foot, LWA)
    origin = data.oMi[foot].translation
    points = origin + rng.normal(size=(4, 3)) * 0.1
    J = np.vstack([J6[:3] - pin.skew(p - origin) @ J6[3:] for p in points])
    U = row_space(J)
    V, S, _ = np.linalg.svd(J, full_matrices=False)
    want = V[:, S > 1e-9 * S[0]]
    assert U.shape == (12, 6)
    np.testing.assert_allclose(U.T @ U, np.eye(6), atol=1e-12)
    np.testing.assert_allclose(U @ U.T, want @ want.T, atol=1e-9)


def test_the_qps_identity_force_task_is_the_explicit_one():
    """whole_body_qp adds an identity ForceTask to P's diagonal: the same P and q as the
    task with its rows given (S = I, through its products)."""
    from humanoid.control.qp import whole_body_qp
    from humanoid.control.tasks import ForceTask, PostureTask, TaskStack

    h = get_model("male", "quaternion")
    model = h.model
    rng = np.random.default_rng(17)
    q, v = random_state(h, rng)
    data = model.createData()
    M, hv = dynamics_terms(model, data, q, v)
    tasks = TaskStack(model, data, q, v)
    tasks.add(PostureTask(h.standing_configuration(), 10.0, 2.0, 0.1))
    Jc = rng.normal(size=(12, model.nv))
    target = rng.normal(size=12)
    fast = whole_body_qp(M, hv, 700.0, tasks, Jc, 0.6, forces=[ForceTask(target, 0.3)])
    slow = whole_body_qp(M, hv, 700.0, tasks, Jc, 0.6,
                         forces=[ForceTask(target, 0.3, np.eye(12))])  # fmt: skip
    np.testing.assert_allclose(fast.P, slow.P, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-12)
