"""Direct tests of the one-line bugs a planted-bug review found surviving (or caught only by a
whole walk): each test here fails with its bug planted. Each runs in well under 5 s."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import BODIES, get_model

import humanoid as hm
from humanoid.constraints import Baumgarte
from humanoid.constraints.foot import PointContact, Weld, _twin
from humanoid.constraints.ground import StepContacts
from humanoid.constraints.solve import stack
from humanoid.contacts import ContactState
from humanoid.control.qp import pyramid_rows
from humanoid.control.tasks import CentreOfMassTask
from humanoid.motion.coordinates import configurations, coordinates_table
from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.inverse_dynamics import inverse_dynamics
from humanoid.motion.markers import Marker, MarkerTrajectories, default_markers, marker_positions
from humanoid.motion.storage import read_storage, write_storage
from humanoid.scene import Contact
from humanoid.study.store import ResultStore
from humanoid.walking.gait import ANGLES, KINETICS, cycle_analysis


@pytest.fixture(scope="module")
def male():
    return get_model("male", "quaternion")


def test_inverse_dynamics_reports_the_root_residuals_in_world_axes(male):
    """Bug: the residuals left in the pelvis' axes. A body held still with its pelvis turned
    45 deg about z and tilted 20 deg about x needs its weight carried straight up, and the
    moment of its weight turns with the pelvis' heading."""
    h = male
    q0 = h.standing_configuration()
    n, dt = 6, 0.01
    weight = pin.computeTotalMass(h.model) * 9.81

    def residuals(R):
        q = q0.copy()
        q[3:7] = pin.Quaternion(R).coeffs()
        r = inverse_dynamics(h, np.arange(n) * dt, np.tile(q, (n, 1)), cutoff=None)
        return r.residual_force[2], r.residual_moment[2]

    turn = pin.exp3(np.array([0.0, 0.0, np.pi / 4]))
    tilted = turn @ pin.exp3(np.array([np.radians(20.0), 0.0, 0.0]))
    f_tilted, m_tilted = residuals(tilted)
    assert np.allclose(f_tilted, [0.0, 0.0, weight], atol=1e-6 * weight)
    f_upright, m_upright = residuals(pin.exp3(np.array([np.radians(20.0), 0.0, 0.0])))
    assert np.linalg.norm(m_upright[:2]) > 1.0  # a moment to turn
    assert np.allclose(m_tilted, turn @ m_upright, atol=1e-6 * weight)


def test_ik_marker_weights_change_the_fit(male):
    """Bug: the weights dropped from the gradient (J' r, not J' W r): every weight-1 test
    passes. One marker moved 5 cm off the others' pose is pulled to much more closely when
    it weighs 100 than when it weighs 1."""
    h = male
    full = default_markers(h)
    names = ["R.ASIS", "L.ASIS", "V.Sacral", "R.Knee.Lat", "L.Knee.Lat", "R.Heel", "L.Heel",
             "R.Toe.Tip", "L.Toe.Tip", "R.Acromium", "L.Acromium", "Top.Head"]  # fmt: skip
    names = [n for n in names if n in full]
    assert len(names) >= 10
    marker_set = {k: full[k] for k in names}
    q = np.tile(h.standing_configuration(), (2, 1))
    positions = marker_positions(h, q, marker_set, names)
    positions[:, names.index("R.Heel"), 0] += 0.05  # 5 cm forward
    markers = MarkerTrajectories(np.arange(2) * 0.01, names, positions)

    def miss(weight):
        m = marker_set["R.Heel"]
        heavy = dict(marker_set, **{"R.Heel": Marker(m.frame, m.offset, weight)})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = inverse_kinematics(h, markers, heavy)
        return r.marker_rms()["R.Heel"]

    light, heavy = miss(1.0), miss(100.0)
    assert heavy < 0.5 * light, (light, heavy)


@pytest.mark.parametrize("flag", [None, True])
def test_a_mot_without_in_degrees_reads_as_degrees(tmp_path, male, flag):
    """Bug: a .mot without an ``inDegrees`` line read as radians (OpenSim reads degrees)."""
    h = male
    q = np.tile(h.standing_configuration(), (4, 1))
    knee = h.model.joints[h.model.getJointId("right_knee")].idx_q
    q[:, knee] = np.radians(40.0)
    table = coordinates_table(h, np.arange(4) * 0.01, q)  # in degrees
    table.in_degrees = flag  # None: no inDegrees line written
    path = write_storage(tmp_path / "c.mot", table)
    assert ("inDegrees" in path.read_text()) == (flag is not None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, got, _ = configurations(h, read_storage(path), floor=False)
    assert np.allclose(got[:, knee], np.radians(40.0))


def test_the_centre_of_mass_task_keeps_its_centre_of_pressure_in_the_support(male):
    """Bug: the centre of pressure c - ddc z / g with the wrong sign. The body asked to move
    its centre of mass forward needs its centre of pressure behind it: a support that holds
    that point leaves the acceleration as asked; a support ahead of the centre of mass holds
    the centre of pressure on its edge (the acceleration turns backward)."""
    h = male
    model, data = h.model, h.model.createData()
    q, v = h.standing_configuration(), np.zeros(model.nv)
    c = pin.centerOfMass(model, data, q).copy()
    g = float(np.linalg.norm(model.gravity.linear))
    kp, d = 40.0, 0.05
    asked = kp * d  # forward [m/s^2]
    cop = c[0] - asked * c[2] / g  # behind c

    def accel(square_at):
        support = square_at + 0.01 * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
        task = CentreOfMassTask(c + [d, 0, 0], np.zeros(3), np.zeros(3), kp, 1.0, 1.0, support)
        _, b = task.compute(model, data, q, v)
        return b

    around_cop = accel(np.array([cop, c[1]]))
    assert around_cop[0] == pytest.approx(asked, rel=1e-6)
    ahead = accel(np.array([c[0] + 0.03, c[1]]))
    pressure = c[0] - ahead[0] * c[2] / (g + ahead[2])
    assert pressure == pytest.approx(c[0] + 0.02, abs=1e-9)  # the square's back edge
    assert ahead[0] < 0.0


def test_a_gait_cycle_is_normalised_from_strike_to_strike(male):
    """Bug: the cycle sampled one sample off. A knee angle equal to the time gives, at each
    percent p of a cycle from t0 to t1, t0 + p (t1 - t0) / 100: 0 % at the strike, 100 % at
    the next one."""
    tk = np.arange(0.0, 3.0001, 0.01)
    n = len(tk)
    angles = {s: np.tile(tk[:, None], (1, len(ANGLES))) for s in ("left", "right")}
    com = np.column_stack([tk, np.zeros(n), np.full(n, 1.0)])
    soles = {"left": np.column_stack([tk, np.full(n, 0.1), np.zeros(n)]),
             "right": np.column_stack([tk, np.full(n, -0.1), np.zeros(n)])}  # fmt: skip
    heading = np.zeros(n)
    contacts = {"left": [(0.2, 0.8), (1.2, 1.8), (2.2, 2.8)],
                "right": [(-np.inf, 0.3), (0.7, 1.3), (1.7, 2.3)]}  # fmt: skip
    percent = np.linspace(0.0, 100.0, 101)
    a = cycle_analysis(male, contacts, tk, tk, (angles, com, soles, heading), mass=75.0,
                       arms=False, percent=percent)  # fmt: skip
    assert a.cycles["left"] == [(0.2, 1.2), (1.2, 2.2)]
    curves = a.curves["left"][ANGLES[0]]
    assert np.allclose(curves[0], 0.2 + percent / 100.0)
    assert np.allclose(curves[1], 1.2 + percent / 100.0)
    assert set(KINETICS).isdisjoint(k for k, c in a.curves["left"].items() if len(c))


def test_retry_failed_reruns_the_failed_runs_only(tmp_path):
    """Bug: ``--retry-failed`` reran the good runs and kept the failed ones."""
    from humanoid.study.spec import parse_study

    study = parse_study({"study": {"name": "s", "run": "scene", "scene": "balance"}})
    store = ResultStore(tmp_path, study)
    for i, status in enumerate(["completed", "failed", "error", "fell", "completed"]):
        store.add({"run": f"r{i}", "index": i, "status": status})
    assert store.finished() == {"r0", "r1", "r2", "r3", "r4"}
    assert store.finished(retry_failed=True) == {"r0", "r3", "r4"}


def test_baumgarte_adds_twice_alpha_times_the_constraint_velocity(male):
    """Bug: the velocity term alpha J v instead of 2 alpha J v (critical damping is
    e'' + 2 alpha e' + beta^2 e = 0), in the stacked solve and in the native twin's Kd."""
    h = male
    model, data = h.model, h.model.createData()
    rng = np.random.default_rng(3)
    q = h.standing_configuration()
    v = rng.normal(size=model.nv)
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    sole = h.sole_id("left")
    anchor = data.oMf[sole].translation + np.array([0.01, -0.02, 0.005])
    c = PointContact("p", sole, anchor)
    alpha, beta = 3.0, 5.0
    J, gamma = stack(model, data, [c], v, Baumgarte(alpha, beta))
    e = c.residual(model, data)
    assert np.linalg.norm(e) > 0.01 and np.linalg.norm(J @ v) > 0.01
    expected = -(c.drift(model, data) + 2 * alpha * (J @ v) + beta**2 * e)
    assert np.allclose(gamma, expected, atol=1e-10)
    twin = _twin(model, sole, pin.ContactType.CONTACT_3D, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
                 pin.SE3.Identity(), Baumgarte(alpha, beta))  # fmt: skip
    gains = twin.m_baumgarte_parameters
    assert np.allclose(np.ravel(gains.Kd), 2 * alpha)
    assert np.allclose(np.ravel(gains.Kp), beta**2)


@pytest.mark.parametrize("side", ["left", "right"])
def test_a_contact_state_holds_its_own_foot(male, side):
    """Bug: the left and right soles swapped in ContactState. The left foot is at +y."""
    h = male
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, h.standing_configuration())
    for kind in ("weld", "points"):
        state = ContactState(h, Contact(foot=side, kind=kind))
        assert state.sole == h.sole_id(side)
        state.attach(data)
        y = [data.oMf[p].translation[1] for p in state.points]
        assert all(np.sign(y) == (1.0 if side == "left" else -1.0))
        frames = {c.frame_id for c in state.constraints if hasattr(c, "frame_id")}
        assert frames == ({h.sole_id(side)} if kind == "weld" else set(state.points))


def test_the_friction_pyramid_is_inscribed_in_the_cone():
    """Bug: the pyramid's half-width mu instead of mu / sqrt 2: its corners then lie outside
    the friction cone. A force at a corner of the inscribed pyramid is on the cone."""
    mu = 0.8
    G = pyramid_rows(mu, 1, 3, 0)
    corner = np.array([mu / np.sqrt(2), mu / np.sqrt(2), 1.0])
    assert np.all(G @ corner <= 1e-12)
    assert np.hypot(*corner[:2]) == pytest.approx(mu * corner[2])
    outside = np.array([mu * 0.9, mu * 0.9, 1.0])  # inside the old, wrong square
    assert np.any(G @ outside > 1e-9)
    assert np.any(G @ np.array([0.0, 0.0, -1.0]) > 0)


def test_the_ground_wrench_moment_is_r_cross_f():
    """Bug: the moment's sign. A vertical force at x = 1 m turns the body about -y; its
    centre of pressure (-ty / fz, tx / fz) is where it acts."""
    step = StepContacts(np.array([[1.0, 0.5, 0.003]]), np.zeros(1), np.array([[0.0, 0.0, 2.0]]),
                        np.zeros(0), 1, True)  # fmt: skip
    w = step.wrench
    assert np.allclose(w, [0, 0, 2.0, 1.0, -2.0, 0.0])
    assert np.allclose([-w[4] / w[2], w[3] / w[2]], [1.0, 0.5])


def test_a_point_contacts_wrench_is_about_its_sole(male):
    """The same sign in a foot's stored wrench: corner forces straight up, their moment about
    the sole origin is r x f (the foot's centre of pressure back at the corners' centre)."""
    h = male
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, h.standing_configuration())
    state = ContactState(h, Contact(foot="left", kind="points"))
    state.attach(data)
    forces = np.tile([0.0, 0.0, 100.0], (4, 1))
    forces[0, 2] = 300.0  # one corner bears more
    state.store(h.model, data, forces.reshape(-1))
    o = data.oMf[state.sole].translation
    arms = np.array([data.oMf[p].translation - o for p in state.points])
    expected = sum(np.cross(r, f) for r, f in zip(arms, forces, strict=True))
    assert np.allclose(state.wrench[3:], expected)
    cop = o[:2] + np.array([-state.wrench[4], state.wrench[3]]) / state.wrench[2]
    pts = np.array([data.oMf[p].translation[:2] for p in state.points])
    assert np.allclose(cop, (forces[:, 2] @ pts) / forces[:, 2].sum(), atol=1e-3)


def test_a_weld_wrench_turns_with_its_sole():
    """Weld.wrench_world: the local force and torque in world axes."""
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
    f = model.addFrame(pin.Frame("sole", j, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    data = model.createData()
    q = pin.neutral(model)
    R = pin.exp3(np.array([0.0, 0.0, np.pi / 2]))
    q[3:7] = pin.Quaternion(R).coeffs()
    pin.framesForwardKinematics(model, data, q)
    weld = Weld("w", f, data.oMf[f])
    out = weld.wrench_world(model, data, np.array([1.0, 0, 0, 0, 2.0, 0]))
    assert np.allclose(out, [0, 1.0, 0, -2.0, 0, 0])


_ = hm  # (the package's import registers the body paths conftest uses)


# --- the survivors of the measurement by scripts/mutation.py (docs/development.md) ---------


def test_a_load_is_zero_outside_its_times():
    """Bug: a load held at its first and last values outside its samples (np.interp's ends):
    a plate's force before and after its recording is none, not the last one measured."""
    from humanoid.motion.loads import Load

    t = np.array([0.1, 0.2])
    f = np.array([[0.0, 0.0, 500.0], [0.0, 0.0, 700.0]])
    load = Load("right", t, f, np.zeros((2, 3)), np.zeros((2, 3)))
    w = load.resampled(np.array([0.0, 0.15, 0.3]))
    assert np.allclose(w[[0, 2]], 0.0)
    assert w[1, 2] == pytest.approx(600.0)


def test_y_up_keypoints_turn_to_our_z_up():
    """Bug: the Y-up keypoints turned with the transposed rotation: OpenSim's up (+y) must be
    our up (+z), its +z (to the right of a walk along +x) our -y."""
    from humanoid.motion.markers import KEYPOINT_LAYOUTS, keypoints

    names = KEYPOINT_LAYOUTS["coco17"]
    pts = np.zeros((1, len(names), 3))
    pts[0, :, 1] = 1.0  # every point 1 m up
    pts[0, 0, 2] = 0.5  # the first 0.5 m along their +z
    m = keypoints(np.zeros(1), pts, "coco17", y_up=True)
    first = m.names.index(next(n for n in names if n is not None))
    assert np.allclose(m.positions[0, :, 2], 1.0)
    assert m.positions[0, first, 1] == pytest.approx(-0.5)


def _short_scene(**kw):
    from humanoid.scene import Scene

    return Scene(**({"body": str(BODIES / "adult_male.urdf"), "duration": 0.1, "dt": 1e-3} | kw))


def test_a_run_takes_the_nearest_whole_number_of_steps_and_records():
    """Bugs: the steps and the recording interval truncated, not rounded: 0.7 s of 1 ms steps
    is 700 steps (0.7 / 0.001 = 699.99...), and 60 Hz at 1 ms records every 17 steps (58.8 Hz,
    the nearest to 60; every 16 is 62.5 Hz)."""
    from humanoid.simulation import Simulation, simulate

    assert Simulation(_short_scene(duration=0.7)).n_steps == 700
    assert Simulation(_short_scene(duration=0.3, dt=1e-4)).n_steps == 3000
    traj = simulate(_short_scene(duration=0.05, record_rate=60.0), quiet=True)
    assert traj.t[1] - traj.t[0] == pytest.approx(0.017, abs=1e-12)


def test_the_plants_inlined_euler_step_moves_q_with_the_new_velocity():
    """Bug: the plant's semi-implicit Euler step (written out, the hot path) moved q with the
    velocity before the step: q+ = q (+) dt v+, v+ = v + dt a(q, v)."""
    from humanoid.simulation import Simulation

    sim = Simulation(_short_scene(integrator="semi_implicit_euler"))
    model = sim.model
    rng = np.random.default_rng(5)
    q0, v0 = sim.q0.copy(), rng.normal(size=model.nv)
    dt = 1e-3
    r = sim.plant.step(0.0, q0, v0, dt)
    a = pin.aba(model, model.createData(), q0, v0, np.zeros(model.nv))
    np.testing.assert_allclose(r.v, v0 + dt * a, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.q, pin.integrate(model, q0, dt * r.v), rtol=0, atol=1e-12)


class _PushesEverywhere:
    """A controller whose force is 10 on every velocity row, the root's six too."""

    def before_step(self, sim, k, t, q, v):
        pass

    def force(self, model, data, t, q, v):
        return np.full(model.nv, 10.0)

    def implicit(self, nv):
        return None


def test_a_controllers_force_on_the_root_is_masked_off():
    """Bug: the joint efforts not masked off the free flyer: a controller's rows for the root
    would push the body as an external force. Masked, the root's rows are zero and the joints'
    are the controller's."""
    from humanoid.simulation import Simulation

    traj = Simulation(_short_scene(duration=0.01)).run(quiet=True, controller=_PushesEverywhere())
    assert traj.status == "completed"
    assert np.all(traj.tau[:, :6] == 0.0)
    assert np.all(traj.tau[1:, 6:] == 10.0)


def _c3d_from_frame_100(path):
    """Two markers over five frames at 100 Hz, the first of them frame 100 (1.0 s)."""
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    c["parameters"]["POINT"]["RATE"]["value"] = [100]
    c["parameters"]["POINT"]["LABELS"]["value"] = ("A", "B")
    pts = np.zeros((4, 2, 5))
    pts[3] = 1.0
    pts[0, 0], pts[1, 1] = 100.0, 1000.0
    c["data"]["points"] = pts
    c["header"]["points"]["first_frame"] = 100
    c.write(str(path))
    return path


def test_a_c3d_starting_at_frame_100_starts_at_1_s(tmp_path):
    """Bug: a C3D's times started at 0 whatever its first frame (its plates' and events'
    times, which start at the first frame's, were then 1 s off its markers')."""
    from humanoid.motion.markers import read_c3d

    m = read_c3d(_c3d_from_frame_100(tmp_path / "t.c3d"))
    np.testing.assert_allclose(m.time, [1.0, 1.01, 1.02, 1.03, 1.04], rtol=0, atol=1e-12)


def test_a_c3d_character_parameter_counts_its_characters(tmp_path):
    """Bug: a character parameter (type -1) sized with its sign: -2 values for two one-letter
    labels. The table counts every parameter's values: POINT:LABELS 1 x 2 characters, UNITS
    "mm" 2, USED one integer (2)."""
    from humanoid.motion.c3d_file import parameter_table

    table = parameter_table(_c3d_from_frame_100(tmp_path / "t.c3d"))
    labels, units, used = (table[("POINT", k)] for k in ("LABELS", "UNITS", "USED"))
    assert (labels.kind, labels.dims, labels.values) == (-1, (1, 2), 2)
    assert (units.kind, units.values) == (-1, 2)
    assert (used.kind, used.values, used.first) == (2, 1, 2)
    assert all(p.values >= 0 for p in table.values())


def test_the_gait_table_reports_each_value_in_its_unit():
    """Bug: the CoM's vertical excursion in the table m x 10, not x 100 (cm). A walk whose
    summary says 4 cm up and down, 3 cm of sway, 60 % stance, 12 % double support and a
    1 mm slide reads so, each against its norm."""
    from humanoid.walking.report import gait_table

    class Walk:
        summary = {"com_vertical": 0.04, "com_lateral": 0.03, "stance": 0.6,
                   "double_support": 0.12, "slip": 0.001}  # fmt: skip
        dimensionless_speed = 0.4

    rows = {label: (value, ok) for label, value, _, ok in gait_table(Walk())}
    assert rows["CoM vertical excursion"] == ("4 cm", True)
    assert rows["CoM lateral sway"] == ("3 cm", True)
    assert rows["stance"] == ("60 % cycle", True)
    assert rows["double support"][0] == "12 % cycle"
    assert rows["largest slide in stance"] == ("1 mm", True)
    assert rows["cadence"] == ("-", None)  # not measured


def test_ik_smoothing_holds_a_joint_towards_the_frame_before(male):
    """Bug: the smoothing's pull with the wrong sign (away from the frame before). Markers of
    the standing body, then of it with its right knee bent 30 deg: without smoothing the
    second frame's knee is 30 deg; with smoothing 1e-6 it lags towards the first frame's
    0 deg (about 11 deg), never past 30."""
    h = male
    full = default_markers(h)
    names = ["R.ASIS", "L.ASIS", "V.Sacral", "R.Knee.Lat", "L.Knee.Lat", "R.Heel", "L.Heel",
             "R.Toe.Tip", "L.Toe.Tip", "R.Acromium", "L.Acromium", "Top.Head"]  # fmt: skip
    marker_set = {k: full[k] for k in names if k in full}
    names = list(marker_set)
    knee = h.model.joints[h.model.getJointId("right_knee")].idx_q
    q = np.tile(h.standing_configuration(), (2, 1))
    q[1, knee] = np.radians(30.0)
    markers = MarkerTrajectories(np.arange(2) * 0.01, names,
                                 marker_positions(h, q, marker_set, names))  # fmt: skip

    def bent(smoothing):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = inverse_kinematics(h, markers, marker_set, smoothing=smoothing)
        assert abs(r.q[0, knee]) < 1e-3
        return r.q[1, knee]

    free = bent(0.0)
    assert free == pytest.approx(np.radians(30.0), abs=2e-3)
    held = bent(1e-6)
    assert 0.05 < held < 0.6 * free, (held, free)


def test_a_studys_fixed_parameters_are_in_its_fingerprint():
    """Bug: the fingerprint blind to the ``[set]`` table: a study edited to another fixed
    value would find the old results under the same run ids and run nothing."""
    from humanoid.study.spec import parse_study

    def study(bmi):
        return parse_study({"study": {"name": "s", "run": "walk"},
                            "set": {"body.bmi": bmi, "body.sex": "male"},
                            "grid": {"body.height": [1.6, 1.8]}})  # fmt: skip

    a, b = study(22.0), study(24.0)
    assert a.fingerprint != b.fingerprint
    assert not {r.id for r in a.runs()} & {r.id for r in b.runs()}
    assert study(22.0).fingerprint == a.fingerprint


def test_a_lognormal_sample_has_the_median_and_geometric_sd_asked():
    """Bug: the geometric standard deviation used as the log's standard deviation (a
    lognormal of 1.05 spread by e^1.05, a factor 2.9). 4000 seeded draws: median 1.7 and
    geometric SD 1.05 within 1 %."""
    from humanoid.study.spec import parse_study

    doc = {"study": {"name": "s", "run": "walk", "seed": 3},
           "set": {"body.bmi": 22.0, "body.sex": "male"},
           "sample": {"n": 4000, "body.height": {"lognormal": [1.7, 1.05]}}}  # fmt: skip
    x = np.array([r.params["body.height"] for r in parse_study(doc).runs()])
    assert np.median(x) == pytest.approx(1.7, rel=0.01)
    assert np.exp(np.std(np.log(x))) == pytest.approx(1.05, rel=0.01)


def test_joint_springs_pull_towards_their_rest_posture(male):
    """tau = -k (q (-) q_rest) on the joints: the right knee 0.1 rad past its rest gets
    -k 0.1 and nothing else moves (the root's rows masked)."""
    from humanoid.effects import JointSprings

    h = male
    model = h.model
    rest = h.standing_configuration()
    knee = model.joints[model.getJointId("right_knee")]
    q = rest.copy()
    q[knee.idx_q] += 0.1
    tau = JointSprings(model, 50.0, rest).force(model, None, 0.0, q, np.zeros(model.nv))
    assert tau[knee.idx_v] == pytest.approx(-5.0, rel=1e-12)
    assert np.abs(np.delete(tau, knee.idx_v)).max() < 1e-12


def test_a_push_of_0_1_plus_0_2_s_acts_on_exactly_200_steps_of_1_ms(male):
    """A window whose end (0.1 + 0.2 = 0.30000000000000004 s) lies a rounding past a step's
    time covers the steps 0.1 <= k dt < 0.3: 200, not 201 (its impulse would be 0.5 % too
    large without the comparisons' tolerance)."""
    from humanoid.effects import Push

    push = Push(male.sole_id("left"), np.array([10.0, 0.0, 0.0]), 0.1, 0.2)
    active = [k for k in range(1000) if push.active(k * 1e-3)]
    assert len(active) == 200 and (active[0], active[-1]) == (100, 299)
