"""Bad input gets a typed error naming what was wrong; nothing is silently wrong."""

from __future__ import annotations

import io
import re
import subprocess
import sys
import zipfile

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model

import humanoid as hm
from humanoid.cli import main
from humanoid.integrators import DormandPrince, LieGroupSpace
from humanoid.model.checks import check_built, validate_urdf

PELVIS, HIP = '<parent link="pelvis"/>', '    <child link="left_hip_flexion_link"/>'
SKIN, RGBA = '<color rgba="0.87 0.72 0.6 1.0"', r"rgba must be in \[0, 1\]"
FIRST_ORIGIN = re.compile(r'(<inertial>\s*<origin xyz=")[^"]*')


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: FIRST_ORIGIN.sub(r"\g<1>0.0,0.0,0.0557", t, 1), r"xyz='0.0,0.0,0.0557'"),
        (lambda t: FIRST_ORIGIN.sub(r"\g<1>0 0 inf", t, 1), r"3 finite number"),
        (lambda t: FIRST_ORIGIN.sub(r"\g<1>0 0", t, 1), r"3 finite number"),
        (lambda t: t.replace('<child link="left_shank"/>', '<child link="left_thigh"/>'),
         r"joint 'left_knee': parent and child are the same link 'left_thigh'"),
        (lambda t: t.replace('<child link="left_shank"/>', '<child link="right_shank"/>'),
         r"link 'right_shank' already has the parent"),
        (lambda t: t.replace('<child link="left_shank"/>', '<child link="nowhere"/>'),
         r"<child link='nowhere'> is not a link"),
        (lambda t: t.replace(f"{PELVIS}\n{HIP}", f'<parent link="left_foot"/>\n{HIP}'),
         r"cycle, not reachable from 'pelvis': left_ankle_flexion_link, left_foot"),
        (lambda t: t.replace('type="revolute"', 'type="hinge"', 1), r"type 'hinge' is not one of"),
        (lambda t: t.replace('<box size="', '<box size="0 ', 1), r"3 finite number"),
        (lambda t: t.replace('<link name="head">', '<link name="pelvis">'), r"links defined twice"),
        # a colour on 0-255 (a planted check against 255 passed every case above)
        (lambda t: t.replace(SKIN, '<color rgba="222 184 153 1.0"', 1), RGBA),
        (lambda t: t.replace(SKIN, '<color rgba="0.87 0.72 0.6 1.5"', 1), RGBA),
    ],
)  # fmt: skip
def test_a_urdf_that_urdfdom_would_misread_is_refused(male_urdf, edit, message):
    """Each of these loaded before (with the cycle, Pinocchio's parser crashed the
    interpreter; with the commas urdfdom dropped the pelvis' inertial: a 66.6 kg body)."""
    bad = edit(male_urdf)
    assert bad != male_urdf
    for mode in ("euler", "quaternion"):
        with pytest.raises(hm.ModelError, match=message):
            hm.load(bad, ball_joints=mode)


def test_what_pinocchio_built_is_compared_with_what_the_urdf_declares(male_urdf):
    declared = validate_urdf(male_urdf, "<string>", None, [])
    model = pin.buildModelFromXML(male_urdf, pin.JointModelFreeFlyer())
    check_built(model, declared, "<string>")  # the shipped body: equal
    declared["left_shank"] = pin.Inertia(1.0, np.zeros(3), np.eye(3) * 0.01)
    with pytest.raises(hm.ModelError, match=r"left_shank: Pinocchio built mass 3\.\d+ kg where "
                       r"the URDF declares 1 kg"):  # fmt: skip
        check_built(model, declared, "<string>")


@pytest.mark.parametrize(
    "bad",
    [
        np.full(49, np.nan),
        {"q": 1},
        "q",
        [10**400] * 49,
        np.ones((2, 49)),
        np.r_[0, 0, 1e7, 0, 0, 0, 1, np.zeros(42)],
    ],
    ids=["nan", "dict", "string", "overflow", "shape", "huge"],
)
def test_bad_states_get_a_configuration_error(bad):
    h = get_model("male", "quaternion")
    for fn in (hm.mass_matrix, hm.gravity_forces, hm.potential_energy, hm.centre_of_mass):
        with pytest.raises(hm.ConfigurationError):
            fn(h, bad)
    q = h.standing_configuration()
    with pytest.raises(hm.ConfigurationError):
        hm.bias_forces(h, q, bad if np.size(bad) != 49 else np.full(41, np.nan))


def test_quaternions_must_be_unit_and_are_normalised_within_tolerance():
    h = get_model("male", "quaternion")
    q = h.standing_configuration()
    q[3:7] = [0.0, 0.0, 0.0, 0.0]
    with pytest.raises(hm.ConfigurationError, match=r"q\[3:7\] is a quaternion of norm 0"):
        hm.mass_matrix(h, q)
    q[3:7] = [0.0, 0.0, 0.0, 1.00005]
    given = q.copy()
    M = hm.mass_matrix(h, q)
    assert np.array_equal(q, given)  # the caller's array is not touched
    q[3:7] = [0.0, 0.0, 0.0, 1.0]
    assert np.allclose(M, hm.mass_matrix(h, q), atol=1e-12)


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("effects.damping", "nan", r"effects.damping: must be a finite number, got nan"),
        ("effects.springs", "nan", r"effects.springs: must be a finite number"),
        ("controller.frequency", "nan", r"controller.frequency: must be a finite number"),
        ("stabilisation.baumgarte", "nan", r"stabilisation.baumgarte: must be a finite"),
        ("duration", "1e400", r"duration: must be a finite number"),
        ("dt", "100000000000000000000000000000000000000000000000000000000000000000000000000000"
         "0000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
         "00000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
         "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000",
         r"dt: the number \d+ is too large"),
    ],
)  # fmt: skip
def test_nan_in_a_scene_is_an_error_never_off(tmp_path, key, value, message):
    table, _, name = key.rpartition(".")
    text = f"[{table}]\n{name} = {value}\n" if table else f"{name} = {value}\n"
    path = tmp_path / "s.toml"
    path.write_text(text)
    with pytest.raises(hm.SceneError, match=message):
        hm.Scene.load(path)


def test_a_push_starting_at_nan_is_an_error(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(
        '[[effects.pushes]]\nframe = "thorax"\nforce = [1, 0, 0]\nstart = nan\nduration = 0.1\n'
    )
    with pytest.raises(hm.SceneError, match=r"effects.pushes\[0\].start: must be a finite"):
        hm.Scene.load(path)


def test_a_deeply_nested_scene_is_a_scene_error(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text("x = " + "[" * 100000 + "]" * 100000 + "\n")
    with pytest.raises(hm.SceneError, match="not valid TOML"):
        hm.Scene.load(path)


def _saved_run(tmp_path):
    traj = hm.simulate(hm.Scene.load("tumble").replace(duration=0.02), quiet=True)
    return traj.save(tmp_path / "run.npz")


def test_corrupt_run_files_get_a_trajectory_error_naming_the_file(tmp_path):
    path = _saved_run(tmp_path)
    data = path.read_bytes()
    cases = {"truncated.npz": data[: len(data) // 2], "garbage.npz": b"not a zip at all",
             "empty.npz": b""}  # fmt: skip
    for name, content in cases.items():
        (tmp_path / name).write_bytes(content)
        with pytest.raises(hm.TrajectoryError, match=name):
            hm.Trajectory.load(tmp_path / name)
    buf = io.BytesIO()
    np.save(buf, np.zeros(3))
    broken = buf.getvalue().replace(b"'shape': (", b"'shape': )h (")  # numpy: SyntaxError
    with zipfile.ZipFile(tmp_path / "header.npz", "w") as zf:
        zf.writestr("t.npy", broken)
    with pytest.raises(hm.TrajectoryError, match="header.npz"):
        hm.Trajectory.load(tmp_path / "header.npz")
    with pytest.raises(hm.TrajectoryError, match="not found"):
        hm.Trajectory.load(tmp_path / "missing.npz")
    good = hm.Trajectory.load(path)
    z = dict(np.load(path))
    z["q"] = z["q"].copy()
    z["q"][1, 0] = np.nan
    np.savez(tmp_path / "nan.npz", **z)
    with pytest.raises(hm.TrajectoryError, match="q has non-finite entries"):
        hm.Trajectory.load(tmp_path / "nan.npz")
    z["q"] = good.q[:, :10]
    np.savez(tmp_path / "short.npz", **z)
    with pytest.raises(hm.TrajectoryError, match="nq = 49, its arrays 10"):
        hm.Trajectory.load(tmp_path / "short.npz")


PLANAR = """<robot name="toy">
  <link name="base"><inertial><mass value="5"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link>
  <link name="left_foot"><inertial><origin xyz="0.1 0 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.1 0.05"/></geometry></collision></link>
  <link name="right_foot"><inertial><origin xyz="0.05 0.02 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.1 0.05"/></geometry></collision></link>
  <joint name="wheel" type="continuous"><parent link="base"/><child link="left_foot"/>
    <origin xyz="0 0.2 -0.3"/><axis xyz="0 1 0"/></joint>
  <joint name="slider" type="planar"><parent link="base"/><child link="right_foot"/>
    <origin xyz="0 -0.2 -0.3"/><axis xyz="0 0 1"/></joint>
</robot>"""


@pytest.mark.parametrize("integrator", ["rk4", "adaptive"])
def test_continuous_and_planar_joints_simulate(tmp_path, integrator):
    """Every joint type Pinocchio loads integrates on its group (a continuous joint keeps
    cos/sin in q, a planar joint is SE(2)); free spinning in zero gravity keeps its energy."""
    urdf = tmp_path / "toy.urdf"
    urdf.write_text(PLANAR)
    h = hm.load(urdf)
    kinds = {h.model.joints[j].shortname() for j in range(2, h.model.njoints)}
    assert kinds == {"JointModelRUBY", "JointModelPlanar"}
    scene = hm.Scene(body=str(urdf), duration=0.5, dt=2e-3, integrator=integrator,
                     initial=hm.scene.Initial(base_velocity=(0.1, 0, 0, 0.3, -0.2, 0.5),
                                              joint_velocity=2.0),
                     effects=hm.scene.Effects(gravity=(0.0, 0.0, 0.0)))  # fmt: skip
    traj = hm.simulate(scene, quiet=True)
    assert traj.status == "completed"
    assert np.ptp(traj.energy) < 1e-7 * traj.energy[0]
    assert np.ptp(traj.q[:, h.model.joints[2].idx_q]) > 0.5  # the wheel turned


def test_dexp_of_a_planar_joint_matches_finite_differences():
    """d' = Jr(d)^-1 w: moving the increment at that rate moves the end point at w."""
    model = pin.Model()
    model.addJoint(0, pin.JointModelPlanar(), pin.SE3.Identity(), "p")
    space = LieGroupSpace(model)
    # Seeded throughout (pin.randomConfiguration draws from Pinocchio's own unseeded generator),
    # and a central difference: a one-sided step of 1e-6 loses the planar rotation in
    # pin.difference for about one start in twelve.
    for seed in range(20):
        rng = np.random.default_rng(seed)
        q0 = pin.integrate(model, pin.neutral(model), rng.normal(size=3))
        d, w = rng.normal(size=3), rng.normal(size=3)
        rate = space.dexp_inv(d, w)
        eps = 1e-4
        ahead = pin.integrate(model, q0, d + eps * rate)
        behind = pin.integrate(model, q0, d - eps * rate)
        moved = pin.difference(model, behind, ahead) / (2 * eps)
        assert np.allclose(moved, w, atol=1e-6), seed


def test_the_adaptive_integrator_gives_up_inside_a_tick():
    """An accepted but ever-smaller step (a body spinning up) stops within one tick."""
    from humanoid.integrators import CoordinateSpace

    def f(t, q, v):
        return -1e10 * q  # a 16 kHz oscillation: steps of ~1e-7 s, all accepted

    dp = DormandPrince(rtol=1e-10, atol=1e-12, max_substeps=500)
    with pytest.raises(hm.DivergenceError, match="took 500 steps inside one tick"):
        dp.advance(CoordinateSpace(1), f, 0.0, np.array([1.0]), np.array([0.0]), 2e-3)
    assert dp.stats.rejected < dp.stats.accepted


def test_output_paths_are_checked_before_the_run(tmp_path, capsys):
    (tmp_path / "dir.npz").mkdir()
    blocked = tmp_path / "file"
    blocked.write_text("x")
    cases = [
        (["walk", "-o", str(tmp_path / "dir.npz")], "-o .*dir.npz: is a folder"),
        (["walk", "--html", str(blocked / "w.html")], "--html .*cannot create"),
        (["simulate", "tumble", "-o", str(blocked / "r.npz")], "-o .*cannot create"),
        (["bench", "step", "-o", str(blocked)], "exists and is not a folder"),
    ]
    for argv, message in cases:
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert re.search(message, err), err
        assert "Traceback" not in err


def test_a_closed_pipe_ends_the_cli_quietly():
    proc = subprocess.Popen([sys.executable, "-m", "humanoid", "info", "talos"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
    proc.stdout.close()  # the reader is gone before the first line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0
    assert err == ""
