"""Motion files, external loads and inverse dynamics (humanoid.motion)."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import BODIES, get_model

import humanoid as hm
from humanoid.motion import MotionFileError, Table, read_storage, write_csv, write_storage
from humanoid.motion.inverse_dynamics import inverse_dynamics, joint_labels, lowpass
from humanoid.motion.loads import OPENSIM_TO_OURS, Load, read_loads, read_loads_xml, write_loads

OPENSIM_IK = """Coordinates
version=1
nRows=3
nColumns=4
inDegrees=yes

Units are S.I. units (second, meters, Newtons, ...)
Angles are in degrees.

endheader
time	pelvis_tilt	knee_angle_r	pelvis_ty
0.00000000	-2.50000000	-4.10000000	0.95000000
0.01000000	-2.60000000	-4.30000000	0.95100000
0.02000000	-2.70000000	-4.50000000	0.95200000
"""


def test_storage_reads_opensim_layout(tmp_path):
    path = tmp_path / "ik.mot"
    path.write_text(OPENSIM_IK)
    t = read_storage(path)
    assert t.in_degrees is True and t.name == "Coordinates"
    assert t.labels == ["pelvis_tilt", "knee_angle_r", "pelvis_ty"]
    np.testing.assert_array_equal(t.time, [0.0, 0.01, 0.02])
    np.testing.assert_array_equal(t.column("knee_angle_r"), [-4.1, -4.3, -4.5])
    assert t.rate == pytest.approx(100.0)


def test_storage_opensim4_header_and_whitespace(tmp_path):
    path = tmp_path / "a.sto"
    path.write_text(
        "version=1\nnRows=2\nnColumns=2\ninDegrees=no\nDataType=double\nversion=3\n"
        "OpenSimVersion=4.5\nendheader\ntime a\n0 1.5\n0.5 2.5\n"
    )
    t = read_storage(path)
    assert t.in_degrees is False and t.header["OpenSimVersion"] == "4.5"
    np.testing.assert_array_equal(t.data[:, 0], [1.5, 2.5])


def test_storage_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(3)
    t = Table(np.arange(5) * 0.01, ["a", "b", "c"], rng.normal(size=(5, 3)) * 1e3, False, "x")
    back = read_storage(write_storage(tmp_path / "x.sto", t))
    np.testing.assert_array_equal(back.data, t.data)
    np.testing.assert_array_equal(back.time, t.time)
    assert back.labels == t.labels and back.in_degrees is False
    lines = write_csv(tmp_path / "x.csv", t).read_text().splitlines()
    assert lines[0] == "time,a,b,c" and len(lines) == 6
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "x.csv", delimiter=",", skiprows=1)[:, 1:],
                                  t.data)  # fmt: skip


@pytest.mark.parametrize(
    "text, message",
    [
        ("version=1\ntime\ta\n0\t1\n", "endheader"),
        ("endheader\nt\ta\n0\t1\n", "first column must be 'time'"),
        ("endheader\ntime\ta\n0\t1\t2\n", "3 values for 2 columns"),
        ("endheader\ntime\ta\n0\tx\n", "not a number"),
        ("endheader\ntime\ta\n0\t1\n0\t2\n", "time does not increase"),
        ("endheader\ntime\ta\ta\n0\t1\t2\n", "repeated column labels"),
    ],
)
def test_storage_errors_name_the_problem(tmp_path, text, message):
    path = tmp_path / "bad.mot"
    path.write_text(text)
    with pytest.raises(MotionFileError, match=message):
        read_storage(path)
    with pytest.raises(MotionFileError, match="not found"):
        read_storage(tmp_path / "missing.mot")
    with pytest.raises(MotionFileError, match="no column 'b'"):
        Table(np.zeros(1), ["a"], np.zeros((1, 1))).column("b")


def test_opensim_axes_are_a_rotation():
    R = OPENSIM_TO_OURS
    np.testing.assert_allclose(R @ R.T, np.eye(3))
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_array_equal(R @ [0, 1, 0], [0, 0, 1])  # their up is ours
    np.testing.assert_array_equal(R @ [0, 0, 1], [0, -1, 0])  # their right is our -y


def test_load_from_wrench_is_exact_and_on_the_plane():
    rng = np.random.default_rng(0)
    w = rng.normal(size=(20, 6)) * [50, 50, 700, 30, 30, 5]
    w[:, 2] = np.abs(w[:, 2]) + 10
    w[3] = [0, 0, 0, 1, 2, 3]  # no force: a pure moment
    load = Load.from_wrench("right", np.arange(20) * 0.01, w, height=0.02)
    np.testing.assert_allclose(load.wrench, w, atol=1e-9)
    on = np.abs(w[:, 2]) > 0
    np.testing.assert_allclose(load.point[on, 2], 0.02)
    np.testing.assert_allclose(load.torque[on, :2], 0.0, atol=1e-9)  # a free moment about z


def test_loads_round_trip_through_opensim_files(tmp_path):
    rng = np.random.default_rng(1)
    t = np.arange(10) * 0.001
    loads = [
        Load(side, t, rng.normal(size=(10, 3)), rng.normal(size=(10, 3)), rng.normal(size=(10, 3)))
        for side in ("right", "left")
    ]
    path = write_loads(tmp_path / "grf.mot", loads)
    assert read_loads_xml(path.with_suffix(".xml")) == {"r_ground_": "right", "l_ground_": "left"}
    back = read_loads(path)  # the .xml next to it names the sides
    for a, b in zip(loads, back, strict=True):
        assert a.body == b.body
        for key in ("force", "point", "torque"):
            np.testing.assert_allclose(getattr(b, key), getattr(a, key), atol=1e-15)
    # in the file, OpenSim's axes: their vertical is our z
    table = read_storage(path)
    np.testing.assert_array_equal(table.column("r_ground_force_vy"), loads[0].force[:, 2])


def test_loads_need_a_side(tmp_path):
    t = Table(np.arange(2.0), [f"{p}ground_force_{w}{c}" for p in ("", "1_") for w in "vp"
                               for c in "xyz"] + [f"{p}ground_torque_{c}" for p in ("", "1_")
                                                  for c in "xyz"], np.zeros((2, 18)))  # fmt: skip
    path = write_storage(tmp_path / "grf.mot", t)
    with pytest.raises(MotionFileError, match="which foot bears the load 'ground_'"):
        read_loads(path)
    loads = read_loads(path, sides={"ground_": "right", "1_ground_": "left"})
    assert [x.body for x in loads] == ["right", "left"]
    with pytest.raises(MotionFileError, match="not an external loads file"):
        read_loads(
            write_storage(tmp_path / "q.mot", Table(np.arange(2.0), ["a"], np.zeros((2, 1))))
        )


def test_lowpass_has_no_lag():
    rate, f = 100.0, 1.0
    t = np.arange(400) / rate
    x = np.sin(2 * np.pi * f * t) + 0.2 * np.sin(2 * np.pi * 30 * t)
    y = lowpass(x, rate, 6.0)
    inner = slice(50, -50)
    # the 1 Hz wave passes with no phase shift, the 30 Hz one is gone
    np.testing.assert_allclose(y[inner], np.sin(2 * np.pi * f * t)[inner], atol=0.01)
    with pytest.raises(hm.HumanoidError, match="cutoff"):
        lowpass(x, rate, 60.0)


def test_joint_labels_cover_every_velocity():
    h = get_model("male", "quaternion")
    labels = joint_labels(h.model)
    assert len(labels) == h.nv and len(set(labels)) == h.nv
    assert labels[:6] == ["root_joint_fx", "root_joint_fy", "root_joint_fz", "root_joint_mx",
                          "root_joint_my", "root_joint_mz"]  # fmt: skip
    assert "right_knee" in labels and "right_hip_y" in labels


def test_inverse_dynamics_of_free_fall_is_zero():
    """A body falling freely (no loads) needs no joint moments and no residual: M a + b = 0
    for a = the free-fall acceleration; the motion is the exact ballistic one, spinning."""
    h = get_model("male", "quaternion")
    model = h.model
    q0 = h.standing_configuration()
    v0 = np.zeros(model.nv)
    v0[:3] = [1.0, 0.2, 3.0]  # the root's velocity, in its frame
    dt, n = 1e-3, 200
    data = model.createData()
    qs, q, v = [q0], q0.copy(), v0.copy()
    for _ in range(n - 1):  # semi-implicit Euler of the free body with zero torque
        a = pin.aba(model, data, q, v, np.zeros(model.nv))
        v = v + dt * a
        q = pin.integrate(model, q, dt * v)
        qs.append(q)
    r = inverse_dynamics(h, np.arange(n) * dt, np.array(qs), cutoff=None, velocity="backward")
    scale = h.mass * 9.81
    assert np.abs(r.tau[1:-1]).max() < 1e-6 * scale
    assert np.abs(r.residual_force[1:-1]).max() < 1e-6 * scale


def test_inverse_dynamics_of_a_standing_body_is_its_weight():
    """Standing still on both feet, the loads carrying the weight at the centre of mass's
    ground point: the residual is zero; without the loads it is the weight, upwards."""
    h = get_model("male", "quaternion")
    q = h.standing_configuration()
    n = 20
    t = np.arange(n) * 0.01
    c = pin.centerOfMass(h.model, h.model.createData(), q)
    W = h.mass * 9.81
    w = np.tile([0, 0, W / 2, c[1] * W / 2, -c[0] * W / 2, 0], (n, 1))
    loads = [Load.from_wrench(s, t, w) for s in ("left", "right")]
    r = inverse_dynamics(h, t, np.tile(q, (n, 1)), loads)
    assert np.abs(r.residual_force).max() < 1e-6 * W
    assert np.abs(r.residual_moment).max() < 1e-6 * W
    bare = inverse_dynamics(h, t, np.tile(q, (n, 1)))
    np.testing.assert_allclose(bare.residual_force, np.tile([0, 0, W], (n, 1)), rtol=1e-9)


def test_inverse_dynamics_errors():
    h = get_model("male", "quaternion")
    q = np.tile(h.standing_configuration(), (5, 1))
    t = np.arange(5) * 0.01
    with pytest.raises(hm.ConfigurationError, match="must be"):
        inverse_dynamics(h, t, q[:, :-1])
    with pytest.raises(hm.HumanoidError, match="at least 3"):
        inverse_dynamics(h, t[:2], q[:2])
    with pytest.raises(hm.HumanoidError, match="does not have"):
        inverse_dynamics(h, t, q, [Load("tail", t, np.zeros((5, 3)), np.zeros((5, 3)),
                                        np.zeros((5, 3)))], cutoff=None)  # fmt: skip
    with pytest.raises(hm.HumanoidError, match="too few"):
        inverse_dynamics(h, t, q, cutoff=6.0)


def test_inverse_dynamics_resamples_a_nonuniform_motion():
    """Samples at uneven times are resampled onto a uniform grid (a still body: exact)."""
    h = get_model("male", "quaternion")
    q = h.standing_configuration()
    t = np.array([0.0, 0.01, 0.025, 0.03, 0.04])
    r = inverse_dynamics(h, t, np.tile(q, (5, 1)), cutoff=None, rate=100.0)
    np.testing.assert_allclose(r.time, [0.0, 0.01, 0.02, 0.03, 0.04])
    np.testing.assert_allclose(r.q, np.tile(q, (5, 1)), atol=1e-12)


# -- round trips through OpenSim's files, on the project's own walk ------------------------


def _export(tmp_path, h, tr, convention="rajagopal"):
    """The walk written as OpenSim files and read back: (time, q, loads)."""
    from humanoid.motion.coordinates import configurations, coordinates_table

    coords = write_storage(tmp_path / "walk.mot", coordinates_table(h, tr.t, tr.q, convention))
    loads = [Load.from_wrench(s, tr.t, tr.forces[f"ground_{s}"]) for s in ("left", "right")]
    grf = write_loads(tmp_path / "walk_grf.mot", loads)
    table = read_storage(coords)
    assert table.in_degrees is True and "knee_angle_r" in table.labels
    t, q, unmapped = configurations(h, table, floor=False)
    assert unmapped == []
    return t, q, read_loads(grf)


@pytest.mark.parametrize("convention", ["rajagopal", "gait2392"])
def test_walk_round_trip_gives_back_the_controller_torques(tmp_path, walk_1khz, convention):
    """The walk's coordinates and ground forces, through .mot files and back, at the
    simulation's rate: inverse dynamics gives back the torques the controller applied (plus
    the joint ranges' moments) to 1e-6 of their peak, and a root residual of the same order;
    the velocity is the backward difference, as the semi-implicit Euler plant defines it."""
    h, tr = walk_1khz
    t, q, loads = _export(tmp_path, h, tr, convention)
    np.testing.assert_allclose(t, tr.t)
    worst = max(np.abs(pin.difference(h.model, a, b)).max() for a, b in zip(q, tr.q, strict=True))
    assert worst < 1e-12
    r = inverse_dynamics(h, t, q, loads, cutoff=None, velocity="backward")
    truth = tr.tau + tr.forces["joint_ranges"]
    peak = np.abs(truth[:, 6:]).max()
    inner = slice(1, -1)  # (the last sample has no next one to take its acceleration from)
    assert np.abs(r.tau[inner, 6:] - truth[inner, 6:]).max() < 1e-6 * peak
    weight = h.mass * 9.81
    assert np.abs(r.residual_force[inner]).max() < 1e-6 * weight
    assert np.abs(r.residual_moment[inner]).max() < 1e-6 * peak


def test_walk_at_100_hz_filtered_is_within_a_few_percent(walk_1khz):
    """Every tenth sample (100 Hz, as a motion lab records) filtered at 6 Hz: the joint
    moments against the controller's torques through the same filter, RMS under 3 % of their
    peak (measured 1.6 %); the root residual's RMS under 5 % of body weight."""
    h, tr = walk_1khz
    loads = [Load.from_wrench(s, tr.t, tr.forces[f"ground_{s}"]) for s in ("left", "right")]
    r = inverse_dynamics(h, tr.t[::10], tr.q[::10], loads, cutoff=6.0)
    truth = lowpass((tr.tau + tr.forces["joint_ranges"])[:, 6:], 1000.0, 6.0)[::10]
    inner = slice(10, -10)  # (the filter's ends)
    e = r.tau[inner, 6:] - truth[inner]
    assert np.sqrt(np.mean(e**2)) < 0.03 * np.abs(truth).max()
    weight = h.mass * 9.81
    assert np.sqrt(np.mean(r.residual_force[inner] ** 2)) < 0.05 * weight


# -- coordinates: OpenSim's gait models onto the body -------------------------------------


def _random_configurations(h, n, seed):
    rng = np.random.default_rng(seed)
    model = h.model
    out = []
    for _ in range(n):
        q = pin.integrate(model, h.standing_configuration(), rng.normal(size=model.nv) * 0.4)
        for j in range(2, model.njoints):
            if model.joints[j].nq == 1:
                k = model.joints[j].idx_q
                q[k] = np.clip(q[k], model.lowerPositionLimit[k], model.upperPositionLimit[k])
        out.append(q)
    return np.array(out)


@pytest.mark.parametrize("name", ["gait2392", "gait2354", "rajagopal"])
def test_coordinates_round_trip(name):
    from humanoid.motion.coordinates import MAPS, configurations, coordinates_table

    h = get_model("male", "quaternion")
    qs = _random_configurations(h, 15, 2)
    table = coordinates_table(h, np.arange(15) * 0.01, qs, name)
    assert table.in_degrees is True
    _, back, unmapped = configurations(h, table, MAPS[name], floor=False)
    assert unmapped == []
    worst = max(np.abs(pin.difference(h.model, a, b)).max() for a, b in zip(qs, back, strict=True))
    assert worst < 1e-12


def _posture(h, **coords):
    """The body's configuration for a one-row gait2392 file with these coordinates [deg]."""
    from humanoid.motion.coordinates import MAPS, configurations

    base = dict.fromkeys(["pelvis_tilt", "pelvis_list", "pelvis_rotation", "pelvis_tx",
                          "pelvis_tz"], 0.0) | {"pelvis_ty": 0.95}  # fmt: skip
    full = [c for jm in MAPS["gait2392"].joints for c in jm.columns]
    cols = base | dict.fromkeys(full, 0.0) | coords
    table = Table(np.zeros(1), list(cols), np.array([list(cols.values())]), True)
    _, q, _ = configurations(h, table, MAPS["gait2392"], floor=False)
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, q[0])
    return q[0], data


def test_coordinates_mean_what_opensim_means():
    """Each coordinate moves the body as it moves OpenSim's model: hip flexion brings the knee
    forward, gait2392's negative knee angle is flexion (the ankle goes back), ankle_angle
    lifts the toes, hip adduction brings the knee in, pelvis_tx/ty are forward and up (their
    Y is our z), a positive lumbar_extension leans the trunk back."""
    h = get_model("male", "quaternion")
    f = h.model.getFrameId

    def pos(data, name):
        return data.oMf[f(name)].translation

    _, d0 = _posture(h)
    _, d = _posture(h, hip_flexion_r=30.0)
    assert pos(d, "right_knee")[0] > pos(d0, "right_knee")[0] + 0.15
    q, d = _posture(h, knee_angle_r=-40.0)
    assert q[h.model.joints[h.model.getJointId("right_knee")].idx_q] == pytest.approx(
        np.radians(40.0)
    )
    assert pos(d, "right_ankle_flexion")[0] < pos(d0, "right_ankle_flexion")[0] - 0.2
    _, d = _posture(h, ankle_angle_r=20.0)
    toe = pos(d, "right_toe_inner")[2] - pos(d, "right_heel_inner")[2]
    assert toe > 0.05
    _, d = _posture(h, hip_adduction_r=15.0, hip_adduction_l=15.0)
    assert pos(d, "right_knee")[1] > pos(d0, "right_knee")[1] + 0.05  # the right knee goes left
    assert pos(d, "left_knee")[1] < pos(d0, "left_knee")[1] - 0.05
    _, d = _posture(h, pelvis_tx=1.0, pelvis_ty=1.25, pelvis_tz=0.5)
    np.testing.assert_allclose(pos(d, "pelvis") - pos(d0, "pelvis"), [1.0, -0.5, 0.3], atol=1e-12)
    _, d = _posture(h, lumbar_extension=20.0)
    assert pos(d, "head")[0] < pos(d0, "head")[0] - 0.1


def test_guess_map_and_opensim4_labels():
    from humanoid.motion.coordinates import coordinate_name, guess_map

    assert coordinate_name("/jointset/hip_r/hip_flexion_r/value") == "hip_flexion_r"
    assert coordinate_name("knee_angle_r") == "knee_angle_r"
    bent = Table(np.arange(2.0), ["knee_angle_r"], np.array([[-30.0], [-5.0]]))
    assert guess_map(bent).name == "gait2392"
    assert guess_map(Table(np.arange(2.0), ["knee_angle_r"], np.array([[30.0], [5.0]]))).name == (
        "rajagopal"
    )


def test_unmapped_columns_are_listed(tmp_path):
    from humanoid.motion.coordinates import MAPS, UnmappedWarning, configurations

    h = get_model("male_foot", "quaternion")  # one-piece feet: no joint for mtp_angle_r
    cols = ["pelvis_tilt", "pelvis_list", "pelvis_rotation", "pelvis_tx", "pelvis_ty",
            "pelvis_tz", "mtp_angle_r", "tail_wag"]  # fmt: skip
    table = Table(np.arange(2.0), cols, np.zeros((2, len(cols))), True, source="x.mot")
    with pytest.warns(UnmappedWarning, match="mtp_angle_r, tail_wag"):
        _, _, unmapped = configurations(h, table, MAPS["gait2392"])
    assert unmapped == ["mtp_angle_r", "tail_wag"]
    with pytest.raises(MotionFileError, match="needs column 'pelvis_tz'"):
        configurations(h, Table(np.arange(2.0), cols[:5], np.zeros((2, 5))), MAPS["gait2392"])
    other = get_model("human", "quaternion")  # example-robot-data's: other joint names
    hips = cols + ["hip_flexion_r", "hip_adduction_r", "hip_rotation_r"]
    with pytest.raises(hm.HumanoidError, match="does not have"):
        configurations(other, Table(np.arange(2.0), hips, np.zeros((2, 11))), MAPS["gait2392"])


def test_user_map_in_toml(tmp_path):
    from humanoid.motion.coordinates import configurations, read_map

    path = tmp_path / "lab.toml"
    path.write_text(
        'name = "lab"\n[root]\nrotation = ["rz", "rx", "ry"]\nrotation_axes = ["z", "x", "y"]\n'
        'translation = ["x", "y", "z"]\ntranslation_axes = ["x", "y", "z"]\n'
        '[joints.right_knee]\ncolumns = ["rknee"]\nsigns = [1]\n'
        '[joints.left_hip]\ncolumns = ["lh1", "lh2", "lh3"]\naxes = ["-y", "-x", "-z"]\n'
    )
    cmap = read_map(path)
    h = get_model("male", "quaternion")
    cols = ["rz", "rx", "ry", "x", "y", "z", "rknee", "lh1", "lh2", "lh3"]
    row = [90.0, 0, 0, 1.0, 2.0, 0.9, 30.0, 10.0, 0, 0]
    _, q, _ = configurations(h, Table(np.zeros(1), cols, np.array([row]), True), cmap,
                             floor=False)  # fmt: skip
    np.testing.assert_allclose(q[0, :3], [1.0, 2.0, 0.9])
    np.testing.assert_allclose(q[0, 3:7], [0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)], atol=1e-12)
    knee = h.model.joints[h.model.getJointId("right_knee")].idx_q
    assert q[0, knee] == pytest.approx(np.radians(30.0))
    bad = tmp_path / "bad.toml"
    bad.write_text('[root]\nrotation = ["a"]\n')
    with pytest.raises(hm.HumanoidError, match=r"\[root\] needs"):
        read_map(bad)
    bad.write_text('[root]\nrotation=[]\nrotation_axes=[]\ntranslation=[]\ntranslation_axes=[]\n'
                   '[joints.right_knee]\ncolumns = ["a", "b"]\nsigns = [1]\n')  # fmt: skip
    with pytest.raises(hm.HumanoidError, match="one per column"):
        read_map(bad)
    with pytest.raises(hm.HumanoidError, match="not found"):
        read_map(tmp_path / "none.toml")


def test_floor_puts_the_stances_on_the_floor():
    """The median over the frames of the lowest sole point goes to z = 0 (where a walk's
    stances are; the lowest of all is an outlier: here a frame dropped 5 cm, which the stances
    must not float over). Each sole point where its own frame has it (the toe points ride on
    the toes: with the toes bent they are not where the rearfoot's sole would have them)."""
    from humanoid.motion.coordinates import MAPS, configurations, coordinates_table

    h = get_model("male", "quaternion")
    qs = _random_configurations(h, 5, 4)
    qs[:, 2] += 0.3
    qs[3, 2] -= 0.05
    table = coordinates_table(h, np.arange(5) * 0.01, qs, "rajagopal")
    _, q, _ = configurations(h, table, MAPS["rajagopal"])
    data = h.model.createData()
    names = [n for s in ("left", "right") for n in h.contact_points[s]]
    low = []
    for qi in q:
        pin.framesForwardKinematics(h.model, data, qi)
        low.append(min(data.oMf[h.frame_id(n)].translation[2] for n in names))
    assert np.median(low) == pytest.approx(0.0, abs=1e-12)


def test_generalized_forces_do_the_same_work():
    """The coordinates' generalised forces times the coordinates' rates is the power of the
    body's own joint moments, for every joint (virtual work: the same forces, other
    coordinates)."""
    from humanoid.motion.coordinates import coordinates_table, generalized_forces_table

    h = get_model("male", "quaternion")
    model = h.model
    rng = np.random.default_rng(5)
    q0 = _random_configurations(h, 1, 6)[0]
    v = rng.normal(size=model.nv)
    tau = rng.normal(size=model.nv) * 10
    dt = 1e-5  # (the tables refuse rates above 100 kHz)
    q1 = pin.integrate(model, q0, v * dt)
    qs = np.array([pin.integrate(model, q0, -v * dt), q0, q1])
    coords = coordinates_table(h, np.arange(3) * dt, qs, "rajagopal", degrees=False)
    rates = (coords.data[2] - coords.data[0]) / (2 * dt)
    forces = generalized_forces_table(h, np.zeros(1), q0[None], tau[None], "rajagopal")
    labels = [x.removesuffix("_moment").removesuffix("_force") for x in forces.labels]
    assert labels == coords.labels
    power = float(forces.data[0] @ rates)
    assert power == pytest.approx(float(tau @ v), rel=1e-6)


def test_cli_id_on_a_run_and_on_opensim_files(tmp_path, walk_1khz, capsys):
    """``humanoid id`` on a saved run (its own ground forces) and on the same walk as OpenSim
    files: the same moments either way, written under OpenSim's names, with a figure."""
    from humanoid.cli import main
    from humanoid.motion.coordinates import coordinates_table

    h, tr = walk_1khz
    run = tr.save(tmp_path / "walk.npz")
    assert main(["id", str(run), "-o", str(tmp_path / "a.sto"), "--map", "gait2392", "--html",
                 str(tmp_path / "a.html")]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert (tmp_path / "a.html").stat().st_size > 100_000
    assert "root residual force" in out and "loads        left (run), right (run)" in out
    a = read_storage(tmp_path / "a.sto")
    assert a.labels[:6] == ["pelvis_tilt_moment", "pelvis_list_moment", "pelvis_rotation_moment",
                            "pelvis_tx_force", "pelvis_ty_force", "pelvis_tz_force"]  # fmt: skip
    assert "knee_angle_r_moment" in a.labels and (tmp_path / "a.png").stat().st_size > 10_000
    write_storage(tmp_path / "walk.mot", coordinates_table(h, tr.t, tr.q, "gait2392"))
    loads = [Load.from_wrench(s, tr.t, tr.forces[f"ground_{s}"]) for s in ("left", "right")]
    write_loads(tmp_path / "grf.mot", loads)
    args = ["id", str(tmp_path / "walk.mot"), "--loads", str(tmp_path / "grf.mot"), "--no-floor",
            "--model", str(BODIES / "adult_male.urdf"), "-o", str(tmp_path / "b.csv")]  # fmt: skip
    assert main(args) == 0
    b = np.loadtxt(tmp_path / "b.csv", delimiter=",", skiprows=1)
    # (the shipped body has toes, which the walk's body had locked: b has their moments too)
    labels = (tmp_path / "b.csv").read_text().splitlines()[0].split(",")[1:]
    assert {"mtp_angle_r_moment", "mtp_angle_l_moment"} <= set(labels) - set(a.labels)
    b = b[:, [1 + labels.index(name) for name in a.labels]]
    np.testing.assert_allclose(b, a.data, atol=1e-6 * np.abs(a.data).max())


def test_cli_id_errors(tmp_path, capsys):
    from humanoid.cli import main

    path = tmp_path / "m.mot"
    path.write_text(OPENSIM_IK)
    assert main(["id", str(path), "--height", "1.8"]) == 2
    assert "go together" in capsys.readouterr().err
    assert main(["id", str(path), "--map", "nonsense"]) == 2
    assert "gait2392" in capsys.readouterr().err
    assert main(["id", str(tmp_path / "none.mot")]) == 2
    assert "not found" in capsys.readouterr().err


# -- markers, keypoints and inverse kinematics ---------------------------------------------


def _spine(model, q):
    """The lumbar and thoracic rotations composed (markers see the two only together)."""
    R = np.eye(3)
    for name in ("lumbar", "thoracic"):
        k = model.joints[model.getJointId(name)].idx_q
        R = R @ pin.Quaternion(q[k : k + 4]).toRotationMatrix()
    return R


def test_ik_gives_back_a_known_motion(walk_1khz):
    """Markers computed from the walk (the default set, every marker) give back its
    configurations through inverse kinematics: every joint to 0.1 degree (the spine's two
    joints as their composed rotation: how the twist is shared between them is not seen by
    markers), the root to 0.1 mm, the markers to 0.5 mm."""
    from humanoid.motion.ik import inverse_kinematics
    from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions

    h, tr = walk_1khz
    model = h.model
    q = tr.q[::20]
    markers = default_markers(h)
    seen = MarkerTrajectories(tr.t[::20], list(markers), marker_positions(h, q, markers))
    r = inverse_kinematics(h, seen, markers)
    assert r.converged.all()
    assert np.nanmax(r.residuals) < 5e-4  # (the pull towards standing: 0.15 mm)
    spine = {model.joints[model.getJointId(n)].idx_v + i for n in ("lumbar", "thoracic")
             for i in range(3)}  # fmt: skip
    others = [i for i in range(6, model.nv) if i not in spine]
    for a, b in zip(q, r.q, strict=True):
        d = pin.difference(model, a, b)
        assert np.degrees(np.abs(d[others]).max()) < 0.1
        assert np.abs(d[:3]).max() < 1e-4
        R = _spine(model, a).T @ _spine(model, b)
        assert np.degrees(np.linalg.norm(pin.log3(R))) < 0.1


def test_ik_keeps_joints_in_range_and_skips_missing_markers():
    """Markers that ask a knee to bend backwards leave it at its range's end; a marker missing
    (NaN) in a frame counts for nothing there and its residual is NaN."""
    from humanoid.motion.ik import inverse_kinematics
    from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions

    h = get_model("male", "quaternion")
    model = h.model
    markers = default_markers(h)
    q = h.standing_configuration()
    knee = model.joints[model.getJointId("right_knee")].idx_q
    bent = q.copy()
    bent[knee] = -0.4  # hyperextended, beyond the range (lower bound 0)
    pos = marker_positions(h, np.array([q, bent]), markers)
    pos[1, list(markers).index("R.Heel")] = np.nan
    r = inverse_kinematics(h, MarkerTrajectories(np.arange(2.0), list(markers), pos), markers)
    lo = model.lowerPositionLimit[knee]
    assert r.q[1, knee] >= lo - 1e-12
    assert r.q[1, knee] == pytest.approx(lo, abs=1e-6)
    assert np.isnan(r.residuals[1, r.names.index("R.Heel")])
    assert np.isfinite(r.residuals[0, r.names.index("R.Heel")])


def test_ik_registers_technical_markers(walk_1khz):
    """A cluster marker the lab put 4 cm from where the set says: with registration the fit
    finds where it is (to 1 mm) and the posture comes back; without, the marker's misfit shows
    in its residual."""
    from humanoid.motion.ik import inverse_kinematics
    from humanoid.motion.markers import (
        Marker,
        MarkerTrajectories,
        default_markers,
        marker_positions,
    )

    h, tr = walk_1khz
    markers = default_markers(h)
    qs = tr.q[::200]
    name = "R.Thigh.Front"
    m = markers[name]
    assert not m.anatomical
    moved = dict(markers)
    moved[name] = Marker(m.frame, tuple(np.array(m.offset) + [0.0, 0.04, 0.0]), 1.0, False)
    seen = MarkerTrajectories(
        np.arange(len(qs)) * 0.2, list(markers), marker_positions(h, qs, moved)
    )
    plain = inverse_kinematics(h, seen, markers)
    assert plain.marker_rms()[name] > 0.005
    fit = inverse_kinematics(h, seen, markers, register=True)
    np.testing.assert_allclose(fit.marker_set[name].offset, moved[name].offset, atol=1e-3)
    assert fit.marker_rms()[name] < 1e-3


def test_marker_set_toml_round_trip(tmp_path):
    from humanoid.motion.markers import default_markers, read_markers, write_markers

    h = get_model("male", "quaternion")
    markers = default_markers(h)
    assert len(markers) >= 60 and markers["R.ASIS"].frame == "pelvis"
    assert read_markers(write_markers(tmp_path / "m.toml", markers)) == markers
    (tmp_path / "bad.toml").write_text('[markers.a]\noffset = [1, 2]\nframe = "pelvis"\n')
    with pytest.raises(hm.HumanoidError, match="3 finite numbers"):
        read_markers(tmp_path / "bad.toml")
    with pytest.raises(hm.HumanoidError, match="toolkit's bodies"):
        default_markers(get_model("talos", "quaternion"))


def test_trc_round_trip_and_opensim_layout(tmp_path):
    from humanoid.motion.markers import MarkerTrajectories, read_trc, write_trc

    rng = np.random.default_rng(9)
    pos = rng.normal(size=(4, 3, 3))
    pos[2, 1] = np.nan
    m = MarkerTrajectories(np.arange(4) / 60.0, ["A", "B.x", "C"], pos)
    back = read_trc(write_trc(tmp_path / "m.trc", m))
    assert back.names == m.names and back.rate == pytest.approx(60.0)
    np.testing.assert_allclose(back.positions, pos, atol=1e-12)
    # OpenSim's layout: padded values, trailing tabs, Y up in millimetres, a blank field
    (tmp_path / "o.trc").write_text(
        "PathFileType\t4\t(X/Y/Z)\to.trc\n"
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
        "\tOrigNumFrames\n60.00\t60.00\t       2\t2\tmm\t60.00\t1\t       2\n"
        "Frame#\tTime\tR.ASIS\t\t\tTop.Head\t\t\t\n\t\tX1\tY1\tZ1\tX2\tY2\tZ2\t\n\n"
        "1\t0.000000\t617.2\t1055.3\t170.8\t\t\t\t\n2\t0.016667\t618.0\t1055.0\t171.0\t1.0\t1800.0\t-2.0\t\n"
    )  # fmt: skip
    o = read_trc(tmp_path / "o.trc")
    np.testing.assert_allclose(o.positions[0, 0], [0.6172, -0.1708, 1.0553])
    assert np.isnan(o.positions[0, 1]).all()
    with pytest.raises(MotionFileError, match="not a TRC"):
        read_trc(write_storage(tmp_path / "x.mot", Table(np.arange(2.0), ["a"], np.zeros((2, 1)))))


def test_keypoints_layouts():
    from humanoid.motion.markers import KEYPOINT_LAYOUTS, default_markers, keypoints

    h = get_model("male", "quaternion")
    markers = default_markers(h)
    for layout, names in KEYPOINT_LAYOUTS.items():
        assert all(n is None or n in markers for n in names), layout
    pts = np.zeros((2, 17, 3))
    k = keypoints(np.arange(2.0), pts, "coco17")
    assert k.names[0] == "head" and "right_ankle" in k.names and len(k.names) == 13
    with pytest.raises(hm.HumanoidError, match=r"\(frames, 24, 3\)"):
        keypoints(np.arange(2.0), pts, "smpl24")
    with pytest.raises(hm.HumanoidError, match="unknown keypoint layout"):
        keypoints(np.arange(2.0), pts, "openpose")


def test_cli_ik_from_trc_and_from_keypoints(tmp_path, walk_1khz, capsys):
    """``humanoid ik`` on the walk's markers as a TRC file gives back its coordinates (0.1
    degree, the spine aside), and on its joint centres as Human3.6M keypoints gives back the
    knees' flexion (joint centres fix it: 0.5 degree, with or without the keypoints' default
    smoothing)."""
    from humanoid.cli import main
    from humanoid.motion.coordinates import coordinates_table
    from humanoid.motion.markers import (
        KEYPOINT_LAYOUTS,
        MarkerTrajectories,
        default_markers,
        marker_positions,
        write_trc,
    )

    h, tr = walk_1khz
    q, t = tr.q[::50], tr.t[::50]
    markers = default_markers(h)
    seen = MarkerTrajectories(t, list(markers), marker_positions(h, q, markers))
    write_trc(tmp_path / "walk.trc", seen)
    body = ["--model", str(BODIES / "adult_male.urdf")]
    out = tmp_path / "ik.mot"
    assert main(["ik", str(tmp_path / "walk.trc"), *body, "-o", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "markers      66 of 66 in the set" in text
    got = read_storage(out)
    want = coordinates_table(h, t, q, "rajagopal")
    for c in ("hip_flexion_r", "knee_angle_l", "ankle_angle_r", "arm_flex_l", "elbow_flex_r"):
        np.testing.assert_allclose(got.column(c), want.column(c), atol=0.1)
    # keypoints: Human3.6M's 17 joint centres (2 of them, spine and thorax, not the body's)
    names = KEYPOINT_LAYOUTS["h36m17"]
    centres = marker_positions(h, q, markers, [n or "pelvis" for n in names])
    np.savez(tmp_path / "kp.npz", points=centres, time=t)
    out = tmp_path / "kp.csv"
    args = ["ik", str(tmp_path / "kp.npz"), "--layout", "h36m17", *body, "-o", str(out), "--quiet"]
    for prior, tolerance in (["--smoothing", "0"], 0.5), ([], 0.5):
        assert main(args + prior) == 0
        got = np.loadtxt(out, delimiter=",", skiprows=1)
        labels = out.read_text().splitlines()[0].split(",")
        for c in ("knee_angle_r", "knee_angle_l"):
            np.testing.assert_allclose(got[:, labels.index(c)], want.column(c), atol=tolerance)
    assert main(["ik", str(tmp_path / "kp.npz"), *body]) == 2
    assert "--layout" in capsys.readouterr().err


# -- physics-based tracking ------------------------------------------------------------------


def _stance_jitter(h, q, reference):
    """Mean horizontal motion per sample [m] of the feet's soles where the reference's sole
    is still (its stance)."""
    model = h.model
    data = model.createData()

    def soles(qs):
        out = {s: [] for s in ("left", "right")}
        for qi in qs:
            pin.framesForwardKinematics(model, data, qi)
            for s in out:
                out[s].append(data.oMf[h.sole_id(s)].translation[:2].copy())
        return {s: np.array(v) for s, v in out.items()}

    ref, got = soles(reference), soles(q)
    moves = []
    for s in ref:
        still = np.linalg.norm(np.diff(ref[s], axis=0), axis=1) < 1e-3
        moves.append(np.linalg.norm(np.diff(got[s], axis=0), axis=1)[still])
    return float(np.mean(np.concatenate(moves)))


def test_tracking_reproduces_the_clean_walk(walk_1khz):
    """The walk's configurations at 100 Hz followed in forward simulation by joint torques
    alone (the root unactuated, on the rigid ground): within 1 cm at the root, 0.5 degree RMS
    over the joints and 2.5 degrees at every joint, all the way (measured at the default 2 ms
    step: 5.7 mm, 0.36 and 2.03 degrees, the worst a hip at a heel strike; at 1 ms 5.9 mm, 0.36
    and 1.99)."""
    from humanoid.motion.tracking import track

    h, tr = walk_1khz
    res = track(h, tr.t[::10], tr.q[::10])
    assert res.completed, res.trajectory.metadata.get("message")
    assert np.abs(res.joint_error[:, :3]).max() < 0.01
    assert np.degrees(np.sqrt(np.mean(res.joint_error[:, 6:] ** 2))) < 0.5
    assert np.degrees(np.abs(res.joint_error[:, 6:]).max()) < 2.5
    assert np.all(res.trajectory.tau[:, :6] == 0.0)  # the root is never actuated
    assert res.trajectory.forces["ground_left"][:, 2].max() > 0.5 * h.mass * 9.81


def test_tracking_cleans_noisy_markers(walk_1khz):
    """The walk's markers with 1 cm of noise (seeded), through inverse kinematics: a motion
    whose joints are 4.63 degrees RMS off and whose standing feet jitter 7.9 mm per sample.
    Tracked, it is physically consistent (a simulation on the ground), its joints closer to the
    clean walk's than the noisy motion's (1.61 degrees RMS) and its standing feet still (0.18
    mm per sample)."""
    from humanoid.motion.ik import inverse_kinematics
    from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions
    from humanoid.motion.tracking import track

    h, tr = walk_1khz
    model = h.model
    t, q = tr.t[::10], tr.q[::10]
    markers = default_markers(h)
    rng = np.random.default_rng(0)
    noisy = marker_positions(h, q, markers) + rng.normal(scale=0.01, size=(len(q), len(markers), 3))
    ik = inverse_kinematics(h, MarkerTrajectories(t, list(markers), noisy), markers)
    res = track(h, t, ik.q)
    assert res.completed, res.trajectory.metadata.get("message")

    def rms(qa, qb):
        d = np.array([pin.difference(model, a, b)[6:] for a, b in zip(qa, qb, strict=True)])
        return float(np.degrees(np.sqrt(np.mean(d**2))))

    tq = res.trajectory.q
    clean = q[np.clip(np.round(res.trajectory.t * 100).astype(int), 0, len(q) - 1)]
    noisy_error, tracked_error = rms(ik.q, q), rms(tq, clean)
    assert noisy_error > 3.0 and tracked_error < 0.5 * noisy_error
    assert _stance_jitter(h, ik.q, q) > 5e-3
    assert _stance_jitter(h, tq, clean) < 1e-3


def test_cli_track(tmp_path, walk_1khz, capsys):
    from humanoid.cli import main
    from humanoid.trajectory import Trajectory

    h, tr = walk_1khz
    run = tr.save(tmp_path / "walk.npz")
    out = tmp_path / "tracked.npz"
    assert main(["track", str(run), "-o", str(out), "--mot", str(tmp_path / "t.mot"),
                 "--quiet"]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert "status       completed" in text and "joint error  RMS" in text
    back = Trajectory.load(out)
    assert back.q.shape[1] == h.nq and np.all(back.tau[:, :6] == 0.0)
    assert (tmp_path / "t_grf.mot").exists() and (tmp_path / "tracked.png").exists()


# -- ground forces without force plates -----------------------------------------------------


def test_estimated_loads_of_a_standing_body_carry_its_weight():
    """Standing still: the estimated ground forces carry the body's weight exactly (the root
    residual vanishes), their centre of pressure under the centre of mass, half on each foot."""
    from humanoid.motion.inverse_dynamics import derivatives, estimate_loads

    h = get_model("male", "quaternion")
    q = np.tile(h.standing_configuration(), (12, 1))
    t, q, v, a = derivatives(h.model, np.arange(12) * 0.01, q, cutoff=None)
    loads = estimate_loads(h, t, q, v, a)
    W = h.mass * 9.81
    total = sum(x.wrench for x in loads)
    np.testing.assert_allclose(total[:, 2], W, rtol=1e-6)
    c = pin.centerOfMass(h.model, h.model.createData(), q[0])
    np.testing.assert_allclose(-total[:, 4] / total[:, 2], c[0], atol=1e-6)  # CoP x
    np.testing.assert_allclose(total[:, 3] / total[:, 2], c[1], atol=1e-6)  # CoP y
    for x in loads:
        np.testing.assert_allclose(x.force[:, 2], W / 2, rtol=1e-3)
    r = inverse_dynamics(h, t, q, loads, cutoff=None)
    assert np.abs(r.residual_force).max() < 1e-6 * W


def test_estimated_loads_of_the_walk(walk_1khz):
    """The walk at 100 Hz with no force plates: its feet's estimated vertical forces are within
    0.2 BW RMS of the simulation's own (through the same 6 Hz filter; measured 0.06-0.14), and
    the knee moments they give within 20 % of their peak RMS of those the true forces give."""
    from humanoid.motion.inverse_dynamics import derivatives, estimate_loads

    h, tr = walk_1khz
    t, q = tr.t[::10], tr.q[::10]
    tt, qf, vf, af = derivatives(h.model, t, q)
    est = estimate_loads(h, tt, qf, vf, af)
    true = [Load.from_wrench(s, tr.t, tr.forces[f"ground_{s}"]) for s in ("left", "right")]
    W = h.mass * 9.81
    for e, x in zip(est, true, strict=True):
        f = lowpass(np.interp(tt, x.time, x.force[:, 2]), 100.0, 6.0)
        assert np.sqrt(np.mean((e.force[:, 2] - f) ** 2)) < 0.2 * W
    a, b = inverse_dynamics(h, t, q, true), inverse_dynamics(h, t, q, est)
    for name in ("right_knee", "left_knee"):
        k = a.labels.index(name)
        peak = np.abs(a.tau[:, k]).max()
        assert np.sqrt(np.mean((a.tau[:, k] - b.tau[:, k]) ** 2)) < 0.2 * peak


def test_contact_schedule_on_a_treadmill(walk_1khz):
    """The walk seen on a treadmill (the body held in place, the ground moving back at the
    walking speed: OpenSim's example trial is such a recording): the feet are found on the
    ground at the same samples as over ground (97 % of them or more)."""
    from humanoid.motion.inverse_dynamics import contact_schedule, derivatives

    h, tr = walk_1khz
    t, q = tr.t[::10], tr.q[::10].copy()
    speed = (q[-1, 0] - q[0, 0]) / (t[-1] - t[0])
    belt = q.copy()
    belt[:, 0] -= speed * (t - t[0])
    over = contact_schedule(h, *derivatives(h.model, t, q)[:3])
    tread = contact_schedule(h, *derivatives(h.model, t, belt)[:3])
    for s in ("left", "right"):
        assert np.mean(over[s][1] == tread[s][1]) >= 0.97
        assert 0.4 < np.mean(tread[s][1]) < 0.8  # (stance: about 60 % of the cycle)


def test_contact_schedule_is_not_fooled_by_a_foot_through_the_floor(walk_1khz):
    """One sample whose foot goes 4 cm through the floor (a rigid foot's tip at push-off in a
    recorded walk, walking5.c3d's toes 4-5 cm under its stances): the motion's floor is the
    median of its lowest sole points, not their lowest, and the stances are found as before
    (on the lowest, no stance at all was found on walking5)."""
    from humanoid.motion.inverse_dynamics import contact_schedule, derivatives

    h, tr = walk_1khz
    t, q = tr.t[::10], tr.q[::10].copy()
    tf, qf, vf = derivatives(h.model, t, q)[:3]
    before = contact_schedule(h, tf, qf, vf)
    dipped = qf.copy()
    dipped[len(tf) // 2, 2] -= 0.04  # (the whole body 4 cm down at one sample)
    after = contact_schedule(h, tf, dipped, vf)
    for s in ("left", "right"):
        assert 0.4 < np.mean(before[s][1]) < 0.8
        assert np.mean(before[s][1] == after[s][1]) >= 0.97


def test_contact_schedule_keeps_a_stance_the_record_cuts(walk_1khz):
    """A record that ends 50 ms after a foot lands (shorter than the 0.1 s a stance must last
    to count: a flicker): that foot is on the ground to the end, and so at its start (without
    it the last frames had no foot down, the loads estimated there were nothing, and residual
    reduction made the body fall there: a hemiparetic walk's reduced motion ended 4 cm
    through the floor)."""
    from humanoid.motion.inverse_dynamics import contact_schedule, derivatives
    from humanoid.walking.gait import contact_runs

    h, tr = walk_1khz
    t, q = tr.t[::10], tr.q[::10]
    right = tr.forces["ground_right"][::10, 2] > 20.0
    (_, lift), (land, _), *_ = contact_runs(right, t, 0.1)  # (the right foot stands first)
    cut = land + 5
    d = derivatives(h.model, t[:cut], q[:cut])[:3]
    on = contact_schedule(h, *d)["right"][1]
    assert on[-3:].all() and not on[lift + 5 : land - 5].any()
    start = land - 5  # (the left foot, mid-swing at the start, and the right's stance cut)
    d = derivatives(h.model, t[start:], q[start:])[:3]
    on = contact_schedule(h, *d)["right"][1]
    assert on[5:10].all()


def test_contact_schedule_fills_the_steps_the_plates_missed(walk_1khz):
    """The walk's own ground forces with the left foot's first stance taken out (a step beside
    the plates): that stance is in the schedule all the same, from the motion (within 50 ms of
    the plates' edges), the plates' timing kept where they saw the foot; with ``fill=False``
    the plates alone, and the step is missing (the tracking of OpenSim's walking5 fell at
    0.37 s so, in flight by the schedule, and completed with the step filled)."""
    from humanoid.motion.inverse_dynamics import contact_schedule, derivatives
    from humanoid.motion.loads import Load
    from humanoid.walking.gait import contact_runs

    h, tr = walk_1khz
    t, q = tr.t[::10], tr.q[::10]
    loads = [Load.from_wrench(s, tr.t, tr.forces[f"ground_{s}"]) for s in ("left", "right")]
    plates = loads[0].force[:, 2] > 20.0
    (a, b), *_ = contact_runs(plates, tr.t, 0.1)
    missed = loads[0].force.copy()
    missed[a:b] = 0.0
    gap = [Load("left", tr.t, missed, loads[0].point, loads[0].torque), loads[1]]
    d = derivatives(h.model, t, q)[:3]
    full = contact_schedule(h, *d, loads)["left"][1]
    filled = contact_schedule(h, *d, gap)["left"][1]
    only = contact_schedule(h, *d, gap, fill=False)["left"][1]
    inside = (t >= tr.t[a] + 0.05) & (t <= tr.t[b - 1] - 0.05)
    assert filled[inside].all() and not only[inside].any()
    later = t > tr.t[b - 1] + 0.1
    np.testing.assert_array_equal(filled[later], full[later])


# -- BVH -------------------------------------------------------------------------------------

SMALL_BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0.0 0.0 0.0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT LeftUpLeg
  {
    OFFSET 10.0 0.0 0.0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LeftLeg
    {
      OFFSET 0.0 -45.0 0.0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0.0 -45.0 0.0
      }
    }
  }
  JOINT Spine
  {
    OFFSET 0.0 60.0 0.0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Head
    {
      OFFSET 0.0 100.0 0.0
      CHANNELS 3 Zrotation Xrotation Yrotation
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0 90 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
5 90 0 90 90 0 0 0 0 0 0 0 0 0 0 0 0 0
"""


def test_bvh_reads_as_blender_does(tmp_path):
    """The channels are intrinsic rotations in their listed order (Zrotation Xrotation
    Yrotation is Rz Rx Ry, degrees), chained parent to child, Y up turned to z up; the unit
    told from the rest pose's height (its joints span 205 units: centimetres); joints named
    after the body's joint centres where their names say which."""
    from humanoid.motion.bvh import read_bvh

    path = tmp_path / "s.bvh"
    path.write_text(SMALL_BVH)
    m = read_bvh(path)
    assert m.names == ["pelvis", "left_hip", "left_knee", "Spine", "head"]
    assert m.rate == pytest.approx(30.0, rel=1e-4)
    # frame 0: the hips at (0, 90, 0) cm, Y up: ours (0, 0, 0.9) m; the left hip 10 cm along
    # their X, our x
    np.testing.assert_allclose(m.positions[0, 0], [0.0, 0.0, 0.9], atol=1e-12)
    np.testing.assert_allclose(m.positions[0, 1], [0.1, 0.0, 0.9], atol=1e-12)
    # frame 1: the root turned Rz(90) Rx(90): their X -> Y, so the hip offset (10, 0, 0) points
    # along their Y (up, our z); the root moved 5 cm along X
    R = pin.exp3(np.array([0, 0, np.pi / 2])) @ pin.exp3(np.array([np.pi / 2, 0, 0]))
    hip = np.array([5.0, 90.0, 0.0]) + R @ np.array([10.0, 0.0, 0.0])
    theirs_to_ours = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    np.testing.assert_allclose(m.positions[1, 1], theirs_to_ours @ hip / 100.0, atol=1e-12)
    knee = hip + R @ np.array([0.0, -45.0, 0.0])
    np.testing.assert_allclose(m.positions[1, 2], theirs_to_ours @ knee / 100.0, atol=1e-12)


def test_bvh_round_trip_of_the_walk(tmp_path, walk_1khz):
    """The walk written as BVH (centimetres, Y up, Z X Y rotations) and read back: every joint
    where the body's forward kinematics puts it, to 1e-6 m; inverse kinematics of those
    joint centres gives back the knees to 0.5 degree (``humanoid ik walk.bvh``)."""
    from humanoid.cli import main
    from humanoid.motion.bvh import read_bvh, write_bvh

    h, tr = walk_1khz
    model = h.model
    data = model.createData()
    t, q = tr.t[::50], tr.q[::50]
    path = write_bvh(tmp_path / "walk.bvh", h, t, q)
    m = read_bvh(path)
    assert len(m.names) == model.njoints - 1
    for i, qi in enumerate(q):
        pin.forwardKinematics(model, data, qi)
        for k in range(1, model.njoints):
            np.testing.assert_allclose(m.positions[i, k - 1], data.oMi[k].translation, atol=1e-6)
    out = tmp_path / "ik.mot"
    body = ["--model", str(BODIES / "adult_male.urdf")]
    assert main(["ik", str(path), *body, "-o", str(out), "--quiet"]) == 0
    from humanoid.motion.coordinates import coordinates_table

    want = coordinates_table(h, t, q, "rajagopal")
    got = read_storage(out)
    for c in ("knee_angle_r", "knee_angle_l"):
        np.testing.assert_allclose(got.column(c), want.column(c), atol=0.5)


def test_bvh_errors(tmp_path):
    from humanoid.motion.bvh import read_bvh

    bad = tmp_path / "b.bvh"
    bad.write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation Zrotation\n}"
                   "\nMOTION\nFrames: 2\nFrame Time: 0.1\n0 0 0\n")  # fmt: skip
    with pytest.raises(MotionFileError, match="'Frames: 2' but 1 rows"):
        read_bvh(bad)
    bad.write_text("not a bvh")
    with pytest.raises(MotionFileError, match="not a BVH"):
        read_bvh(bad)


def test_c3d_markers(tmp_path):
    """A C3D written by ezc3d: points in millimetres to metres, a point with a negative
    residual (ezc3d's missing) or NaN read as NaN, Z up kept, Y up (POINT:Y_SCREEN +Y) turned."""
    import ezc3d

    from humanoid.motion.markers import read_c3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    c["parameters"]["POINT"]["RATE"]["value"] = [100]
    c["parameters"]["POINT"]["LABELS"]["value"] = ("A", "B")
    pts = np.zeros((4, 2, 5))
    pts[3] = 1.0
    pts[0, 0] = 100.0  # A at x = 0.1 m
    pts[1, 1] = 1000.0  # B at y = 1 m
    pts[:3, 1, 2] = np.nan
    c["data"]["points"] = pts
    path = tmp_path / "t.c3d"
    c.write(str(path))
    m = read_c3d(path)
    assert m.names == ["A", "B"] and m.rate == pytest.approx(100.0)
    np.testing.assert_allclose(m.positions[0, 0], [0.1, 0.0, 0.0])
    np.testing.assert_allclose(m.positions[0, 1], [0.0, 1.0, 0.0])
    assert np.isnan(m.positions[2, 1]).all()
    up = read_c3d(path, y_up=True)  # their Y (1 m) is our z
    np.testing.assert_allclose(up.positions[0, 1], [0.0, 0.0, 1.0], atol=1e-12)
    with pytest.raises(MotionFileError, match="not found"):
        read_c3d(tmp_path / "none.c3d")


def test_loads_are_carried_with_the_feet_the_markers_show():
    """A recording whose feet stood 4 cm ahead and 3 cm out of where the body's stand (another
    person's legs): its force plates' loads, applied where they were measured, leave the
    standing body a residual moment of its weight times that offset; carried with the feet
    that the foot markers show (``recorded_feet``), none."""
    from humanoid.motion.inverse_dynamics import recorded_feet
    from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions

    h = get_model("male", "quaternion")
    n = 12
    t = np.arange(n) * 0.01
    q = np.tile(h.standing_configuration(), (n, 1))
    data = h.model.createData()
    c = pin.centerOfMass(h.model, data, q[0])
    W = h.mass * 9.81
    d = {"left": np.array([0.04, 0.03, 0.0]), "right": np.array([0.04, -0.03, 0.0])}
    loads = []
    for s in ("left", "right"):  # each foot half the weight, under the centre of mass's x
        pin.framesForwardKinematics(h.model, data, q[0])
        foot = data.oMf[h.sole_id(s)].translation
        p = np.array([c[0], foot[1], 0.0]) + d[s]
        loads.append(Load(s, t, np.tile([0, 0, W / 2], (n, 1)), np.tile(p, (n, 1)),
                          np.zeros((n, 3))))  # fmt: skip
    markers = default_markers(h)
    pos = marker_positions(h, q, markers)
    for k, name in enumerate(markers):
        for s in ("left", "right"):
            if markers[name].frame == f"{s}_foot":
                pos[:, k] += d[s]
    seen = MarkerTrajectories(t, list(markers), pos)
    plain = inverse_dynamics(h, t, q, loads, cutoff=None)
    assert np.abs(plain.residual_moment).max() > 0.5 * W * 0.04
    feet = recorded_feet(h, t, q, seen, markers)
    carried = inverse_dynamics(h, t, q, loads, cutoff=None, recorded_feet=feet)
    assert np.abs(carried.residual_moment).max() < 1e-6 * W
    assert [x[0] for x in carried.carried] == ["left", "right"]
    np.testing.assert_allclose(carried.carried[0][3:], [-0.04, -0.03], atol=1e-9)


def test_tracking_cleans_noisy_keypoints(walk_1khz):
    """OpenPose's BODY_25 keypoints of the walk (joint centres, the feet's toes and heels) with
    1 cm of noise: their fitted motion is about 4 degrees RMS off; tracked, the walk completes
    closer to the clean one, its standing feet still."""
    from humanoid.motion.ik import inverse_kinematics
    from humanoid.motion.markers import (
        KEYPOINT_LAYOUTS,
        MarkerTrajectories,
        default_markers,
        marker_positions,
    )
    from humanoid.motion.tracking import track

    h, tr = walk_1khz
    model = h.model
    t, q = tr.t[::10], tr.q[::10]
    markers = default_markers(h)
    names = [n for n in KEYPOINT_LAYOUTS["body25"] if n]
    rng = np.random.default_rng(0)
    noisy = marker_positions(h, q, markers, names) + rng.normal(scale=0.01, size=(len(q), 20, 3))
    fit = inverse_kinematics(h, MarkerTrajectories(t, names, noisy), markers)
    res = track(h, t, fit.q)
    assert res.completed, res.trajectory.metadata.get("message")

    def rms(qa, qb):
        d = np.array([pin.difference(model, a, b)[6:] for a, b in zip(qa, qb, strict=True)])
        return float(np.degrees(np.sqrt(np.mean(d**2))))

    clean = q[np.clip(np.round(res.trajectory.t * 100).astype(int), 0, len(q) - 1)]
    assert rms(res.trajectory.q, clean) < rms(fit.q, q) < 6.0
    assert _stance_jitter(h, res.trajectory.q, clean) < 1e-3


def test_joint_centres_alone_stand_on_level_feet_and_track(walk_1khz, monkeypatch):
    """Human3.6M's 17 joint centres (the ankles' centres, nothing of the feet): the fit pulls a
    stance foot's sole level through the ankle (its coordinates no point sees), and the walk
    with 1 cm of noise tracks to the end (measured: fitted 3.3 deg RMS off, tracked 2.9; its
    pelvis strays over 10 cm from the motion's at 1.36 s, a run that completes, not one that
    follows);
    without the pull the ankles are held as they fall and the tracked body loses the motion
    within a second (measured: at 0.6 s; it then stands 1.3 m behind it, or falls). The clean
    points' knees come back to 0.5 deg (the pull moves no coordinate the points see). COCO's
    17 see no foot either; BODY_25 (toes and heels) and markers do."""
    import humanoid.motion.ik as ik
    from humanoid.motion.markers import (
        KEYPOINT_LAYOUTS,
        MarkerTrajectories,
        default_markers,
        marker_positions,
    )
    from humanoid.motion.tracking import lost_at, track

    h, tr = walk_1khz
    t, q = tr.t[::10], tr.q[::10]
    markers = default_markers(h)

    def points(layout, tt=t, qq=q):
        names = [n for n in KEYPOINT_LAYOUTS[layout] if n] if layout else list(markers)
        return MarkerTrajectories(tt, names, marker_positions(h, qq, markers, names))

    assert ik._feet_unseen(h, points("coco17"), markers)
    assert not ik._feet_unseen(h, points("body25"), markers)
    assert not ik._feet_unseen(h, points(None), markers)
    knees = [h.model.joints[h.model.getJointId(f"{s}_knee")].idx_q for s in ("left", "right")]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = ik.inverse_kinematics(h, points("h36m17", tr.t[::50], tr.q[::50]), markers)
    assert np.degrees(np.abs(clean.q[:, knees] - tr.q[::50][:, knees])).max() < 0.5
    seen = points("h36m17")
    noisy = MarkerTrajectories(t, seen.names, seen.positions + np.random.default_rng(0).normal(
        scale=0.01, size=seen.positions.shape))  # fmt: skip

    def rms(qa, qb):
        d = np.array([pin.difference(h.model, a, b)[6:] for a, b in zip(qa, qb, strict=True)])
        return float(np.degrees(np.sqrt(np.mean(d**2))))

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = ik.inverse_kinematics(h, noisy, markers)
        res = track(h, t, fit.q)
        monkeypatch.setattr(ik, "LEVEL_SOLES", 0.0)
        fell = track(h, t, ik.inverse_kinematics(h, noisy, markers).q)
    assert res.completed, res.trajectory.metadata.get("message")
    ref = q[np.clip(np.round(res.trajectory.t * 100).astype(int), 0, len(q) - 1)]
    assert rms(res.trajectory.q, ref) < min(5.0, rms(fit.q, q))
    # (the run may end standing where it lost the motion, or on the floor: lost either way)
    lost = lost_at(fell.joint_error)
    assert fell.lost is not None and fell.lost == fell.trajectory.t[lost] < 1.0


def test_inverse_dynamics_ignores_quaternion_signs(walk_1khz):
    """q and -q are one rotation: a motion whose quaternions flip sign from sample to sample
    gives the same moments as the one that does not."""
    from humanoid.motion.inverse_dynamics import quaternion_slots

    h, tr = walk_1khz
    q = tr.q[::10].copy()
    flipped = q.copy()
    rng = np.random.default_rng(4)
    for s in quaternion_slots(h.model):
        flip = rng.random(len(q)) < 0.5
        flipped[flip, s : s + 4] *= -1.0
    a = inverse_dynamics(h, tr.t[::10], q)
    b = inverse_dynamics(h, tr.t[::10], flipped)
    np.testing.assert_allclose(b.tau, a.tau, atol=1e-9 * np.abs(a.tau).max())
