"""Hard cases of articulated-body simulation: each stays finite with bounded invariant drift, or
stops with the clear divergence error, never NaN silently. Bounds are stated next to each test
together with what was measured on this machine when the test was written."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import BODIES, get_model

import humanoid as hm
from humanoid.errors import ConfigurationError, SceneError
from humanoid.integrators import LieGroupSpace, explicit_euler, rk4, semi_implicit_euler
from humanoid.scene import Contact, Controller, Effects, Initial, Scene, Stabilisation
from humanoid.simulation import Simulation, simulate

MALE = str(BODIES / "adult_male.urdf")


# -- 1. intermediate-axis (Dzhanibekov) tumbling --------------------------------------------
def _tumbler():
    """One free rigid body with principal inertias (1, 2, 3) kg m^2, spun about the
    intermediate axis with a small perturbation: it flips periodically."""
    model = pin.Model()
    jid = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "free")
    model.appendBodyToJoint(
        jid, pin.Inertia(1.0, np.zeros(3), np.diag([1.0, 2.0, 3.0])), pin.SE3.Identity()
    )
    model.gravity = pin.Motion.Zero()
    data = model.createData()
    q0 = pin.neutral(model)
    v0 = np.array([0, 0, 0, 0.01, 2.0, 0.0])

    def f(t, q, v):
        return pin.aba(model, data, q, v, np.zeros(6)).copy()

    return model, q0, v0, f


def _invariants(model, q, v):
    data = model.createData()
    energy = pin.computeKineticEnergy(model, data, q, v)
    R = pin.Quaternion(q[3:7]).toRotationMatrix()
    L = R @ (model.inertias[1].inertia @ v[3:6])  # world angular momentum (CoM at the origin)
    return energy, L


def _tumble(scheme, dt, T):
    model, q, v, f = _tumbler()
    space = LieGroupSpace(model)
    e0, L0 = _invariants(model, q, v)
    flips, sign = 0, np.sign(v[4])
    for k in range(int(round(T / dt))):
        q, v = scheme(space, f, k * dt, q, v, dt)
        if np.sign(v[4]) != sign:
            flips, sign = flips + 1, np.sign(v[4])
    e, L = _invariants(model, q, v)
    return abs(e - e0) / e0, np.linalg.norm(L - L0) / np.linalg.norm(L0), flips, q


def test_dzhanibekov_rk4_keeps_energy_and_momentum():
    """RK4 at 5 ms over 60 s (5 flips): relative drifts below 1e-8 (measured: energy 1e-12,
    angular momentum 8e-11)."""
    de, dL, flips, q = _tumble(rk4, 5e-3, 60.0)
    assert flips >= 4, f"only {flips} flips"  # measured 5 sign changes of the spin in 60 s
    assert de < 1e-8 and dL < 1e-8, (de, dL)
    assert abs(np.linalg.norm(q[3:7]) - 1.0) < 1e-14


@pytest.mark.parametrize("scheme", [explicit_euler, semi_implicit_euler])
def test_dzhanibekov_first_order_schemes_drift_as_their_order_says(scheme):
    """First order: the energy error over 5 s halves (ratio ~2) when the step halves."""
    errors = [_tumble(scheme, dt, 5.0)[0] for dt in (4e-3, 2e-3, 1e-3)]
    ratios = [errors[i] / errors[i + 1] for i in range(2)]
    assert all(1.6 < r < 2.5 for r in ratios), (errors, ratios)
    assert errors[-1] < 1e-2


# -- 2. straight knees with both feet welded --------------------------------------------------
@pytest.mark.parametrize(
    "gravity", [(0.0, 0.0, -9.81), (0.0, 0.0, 0.0)], ids=["loaded", "unloaded"]
)
def test_straight_knees_both_feet_welded(gravity):
    """Passive body on welded feet, knees exactly straight (a singular leg Jacobian), with
    random joint velocities: finite, constraint residual below 1e-6 m over 1 s."""
    scene = Scene(
        body=MALE, duration=1.0, dt=1e-3, integrator="rk4",
        effects=Effects(gravity=gravity, contacts=(Contact("left"), Contact("right")), damping=1.0,
                        joint_limits=hm.scene.JointLimitSpec()),
        initial=Initial(joint_velocity=0.3), stabilisation=Stabilisation(baumgarte=20.0),
    )  # fmt: skip
    traj = simulate(scene, quiet=True)
    assert traj.status == "completed", traj.metadata["message"]
    assert np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.v))
    assert traj.metadata["max_residual"] < 1e-6


# -- 3. redundant point contacts held for a long stance ---------------------------------------
def test_redundant_point_contacts_long_stance():
    """Four point contacts per sole (24 rows, rank 12), posture hold, 5 s: finite, residual
    below 1e-8 m, vertical forces sum to the weight (measured: residual ~1e-16)."""
    feet = (Contact("left", "points"), Contact("right", "points"))
    scene = Scene(
        body=MALE, duration=5.0, dt=2e-3, integrator="semi_implicit_euler",
        effects=Effects(contacts=feet), controller=Controller("posture", frequency=8.0),
        stabilisation=Stabilisation(baumgarte=20.0),
    )  # fmt: skip
    traj = simulate(scene, quiet=True)
    assert traj.status == "completed", traj.metadata["message"]
    assert traj.metadata["max_residual"] < 1e-8
    fz = traj.forces["left"][:, 2] + traj.forces["right"][:, 2]
    assert np.allclose(fz, 75.0 * 9.81, rtol=1e-6)


# -- 4. gimbal lock of erd's hinge triplets ---------------------------------------------------
def _gimbal_scene(mode: str) -> Scene:
    """erd's human floating in zero gravity, its left hip's middle hinge driven through
    pi/2 by its velocity (the X hinge's limit is pi/2 - 1.3e-6)."""
    he = get_model("human", "euler")
    m = he.model
    q = he.standing_configuration()
    jm = m.joints[m.getJointId("left_hip_X")]
    q[jm.idx_q] = np.pi / 2 - 0.05
    v = np.zeros(m.nv)
    v[jm.idx_v] = 1.0
    if mode == "quaternion":
        q, v = get_model("human", "quaternion").from_euler(q, v)
    path, _ = hm.model.example_robot_path("human")
    return Scene(
        body=str(path), ball_joints=mode, duration=0.1, dt=1e-4, integrator="rk4",
        effects=Effects(gravity=(0.0, 0.0, 0.0)),
        initial=Initial(configuration=tuple(q), base_velocity=tuple(v[:6]),
                        joint_velocity=tuple(v[6:])),
    )  # fmt: skip


def test_euler_mode_reports_gimbal_lock():
    traj = simulate(_gimbal_scene("euler"), quiet=True)
    events = [e for e in traj.metadata["events"] if e["event"] == "gimbal_lock"]
    assert events, "crossing the hip's gimbal lock went unreported"
    assert events[0]["joint"] == "left_hip" and "singular" in events[0]["reason"]
    # whatever happens after it, no NaN is recorded silently
    assert traj.status in ("completed", "diverged")
    assert np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.v))


def test_quaternion_mode_simulates_through_gimbal_lock():
    """The same motion with spherical joints: no event, energy kept to 1e-9 relative."""
    traj = simulate(_gimbal_scene("quaternion"), quiet=True)
    assert traj.status == "completed", traj.metadata["message"]
    assert not [e for e in traj.metadata["events"] if e["event"] == "gimbal_lock"]
    e = traj.energy
    assert abs(e[-1] - e[0]) < 1e-9 * abs(e[0])
    # it really went through: the Euler angles of the left hip pass pi/2
    h = get_model("human", "quaternion")
    iq = h.euler_model.joints[h.euler_model.getJointId("left_hip_X")].idx_q
    angles = [h.to_euler(q)[0][iq] for q in traj.q]
    assert min(angles) < np.pi / 2 - 0.01 and np.isfinite(angles).all()


# -- 5. massless links and very light segments at high speed ----------------------------------
def test_light_segments_spinning_fast():
    """Hands and feet (0.46 kg, 1.0 kg, behind massless links) whipped at 30 rad/s in zero
    gravity: finite, energy conserved to 1e-6 relative with RK4 at 0.2 ms."""
    h = get_model("male", "quaternion")
    v = np.zeros(h.nv)
    for name in ("left_wrist_flexion", "right_wrist_deviation", "left_ankle_flexion",
                 "right_ankle_inversion", "left_elbow"):  # fmt: skip
        v[h.model.joints[h.model.getJointId(name)].idx_v] = 30.0
    scene = Scene(
        body=MALE, duration=0.2, dt=2e-4, integrator="rk4", effects=Effects(gravity=(0, 0, 0)),
        initial=Initial(base_velocity=tuple(v[:6]), joint_velocity=tuple(v[6:])),
    )  # fmt: skip
    traj = simulate(scene, quiet=True)
    assert traj.status == "completed"
    assert abs(traj.energy[-1] - traj.energy[0]) < 1e-6 * traj.energy[0]


# -- 6. stiff PD gains and large steps near the stability limit -------------------------------
@pytest.mark.parametrize("frequency", [4.0, 60.0, 400.0])
def test_stiff_gains_are_stable_or_reported(frequency):
    """A posture hold at 4, 60 and 400 Hz with explicit Euler at 2 ms (stable below about
    w dt < 2 for the stiffest mode): completes, or stops with the divergence message; the
    records never hold NaN."""
    scene = Scene(
        body=MALE, duration=1.0, dt=2e-3, integrator="euler",
        effects=Effects(contacts=(Contact("left"), Contact("right"))),
        controller=Controller("posture", frequency=frequency),
    )  # fmt: skip
    traj = simulate(scene, quiet=True)
    assert np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.v))
    if frequency >= 400.0:  # w dt = 2 pi 400 * 0.002 = 5: beyond the limit
        assert traj.status == "diverged"
        assert "exploding" in traj.metadata["message"] or "non-finite" in traj.metadata["message"]
    if frequency <= 4.0:
        assert traj.status == "completed"


# -- 7. long horizons ---------------------------------------------------------------------------
def test_ten_minutes_of_welded_stance():
    """10 simulated minutes of standing on welded feet with a posture hold (native backend,
    semi-implicit Euler, 2 ms): constraint drift below 1e-9 m and quaternion norms within
    1e-12 of 1 at every record (measured: 4e-16 and 2e-16)."""
    scene = Scene(
        body=MALE, duration=600.0, dt=2e-3, integrator="semi_implicit_euler", record_rate=10.0,
        effects=Effects(contacts=(Contact("left"), Contact("right"))),
        controller=Controller("posture", frequency=8.0),
        stabilisation=Stabilisation(baumgarte=20.0, backend="native"),
    )  # fmt: skip
    traj = simulate(scene, quiet=True)
    assert traj.status == "completed", traj.metadata["message"]
    assert traj.t[-1] == pytest.approx(600.0)
    assert np.nanmax(traj.residual) < 1e-9
    h = get_model("male", "quaternion")
    for jm in h.model.joints[1:]:
        if jm.nq in (4, 7):
            iq = jm.idx_q + (3 if jm.nq == 7 else 0)
            norms = np.linalg.norm(traj.q[:, iq : iq + 4], axis=1)
            assert np.abs(norms - 1.0).max() < 1e-12


# -- 8. bad numbers in ------------------------------------------------------------------------
def test_non_finite_input_is_rejected_at_entry(tmp_path):
    h = get_model("male", "quaternion")
    q = h.standing_configuration()
    q[9] = np.inf
    with pytest.raises(ConfigurationError, match="non-finite"):
        hm.mass_matrix(h, q)
    with pytest.raises(SceneError, match=r"base_velocity\[2\]: must be a finite number"):
        Scene(body=MALE, initial=Initial(base_velocity=(0, 0, np.nan, 0, 0, 0)))
    with pytest.raises(SceneError, match=r"force\[1\]: must be a finite number"):
        Scene(
            body=MALE,
            effects=Effects(pushes=(hm.scene.PushSpec("thorax", (1.0, np.inf, 0.0), 0, 1),)),
        )
    with pytest.raises(SceneError, match=r"gravity\[1\]: must be a finite number"):
        Scene(body=MALE, effects=Effects(gravity=(0.0, np.nan, -9.81)))
    bad = tmp_path / "bad.toml"
    bad.write_text(f'[body]\nurdf = "{MALE}"\n[initial]\nbase_velocity = [0, 0, nan, 0, 0, 0]\n')
    with pytest.raises(SceneError, match=r"bad.toml: initial.base_velocity\[2\]: must be a fin"):
        Scene.load(bad)
    sim = Simulation(Scene(body=MALE, duration=0.01))
    with pytest.raises(ConfigurationError):
        hm.bias_forces(h, sim.q0, np.full(h.nv, np.nan))
