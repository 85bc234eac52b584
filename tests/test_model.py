"""Loading humanoid URDFs: ours and others', up-axis, feet, contact points, clear errors."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest
from conftest import BODIES, get_model

import humanoid as hm
from humanoid.model import example_robot_path


def _world(h, q, names):
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, q)
    return np.array([data.oMf[h.model.getFrameId(n)].translation for n in names])


@pytest.mark.parametrize("name", ["male", "female", "human", "talos"])
@pytest.mark.parametrize("mode", ["euler", "quaternion"])
def test_loaded_model_stands_on_its_soles(name, mode):
    h = get_model(name, mode)
    assert h.model.joints[1].shortname() == "JointModelFreeFlyer"
    assert h.model.names[1] == "root_joint"
    q = h.standing_configuration()
    points = _world(h, q, h.contact_points["left"] + h.contact_points["right"])
    assert np.abs(points[:, 2]).max() < 1e-9, "sole points not on z = 0"
    left, right = points[:4], points[4:]
    assert left[:, 1].min() > right[:, 1].max(), "left foot is not on +y"
    heel, toe = points[[0, 1]], points[[2, 3]]
    assert toe[:, 0].min() > heel[:, 0].max(), "toes are not in front of the heels (+x)"
    # The body stands along +Z: the pelvis is above the feet and the CoM between them.
    com = hm.centre_of_mass(h, q)
    assert q[2] > 0.5
    assert points[:, 0].min() - 0.05 < com[0] < points[:, 0].max() + 0.05
    assert right[:, 1].max() < com[1] + 0.05 and com[1] - 0.05 < left[:, 1].min()
    # The sole frames are flat and world-aligned
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, q)
    for foot in h.feet:
        assert np.allclose(data.oMf[h.model.getFrameId(foot)].rotation, np.eye(3), atol=1e-9)


def test_erd_human_is_turned_z_up():
    h = get_model("human", "euler")
    data = h.model.createData()
    q = h.standing_configuration()
    pin.framesForwardKinematics(h.model, data, q)
    head = data.oMf[h.model.getFrameId("middle_head")].translation
    assert head[2] > 1.3, f"head at {head}"
    assert h.standing_height() == pytest.approx(1.80, abs=0.05)  # erd's body is 1.80 m
    assert h.mass == pytest.approx(74.712, abs=1e-9)  # the URDF's masses, unchanged


def test_our_body_height_and_com_ratio():
    for name, height in (("male", 1.75), ("female", 1.62)):
        h = get_model(name, "quaternion")
        assert h.standing_height() == pytest.approx(height, abs=1e-12)
        ratio = hm.centre_of_mass(h, h.standing_configuration())[2] / height
        assert 0.53 <= ratio <= 0.58, f"{name}: CoM at {ratio:.4f} x stature"


def test_load_from_text_and_from_path_agree(male_urdf):
    a = hm.load(male_urdf)
    b = get_model("male", "quaternion")
    assert a.model.nq == b.model.nq and a.mass == pytest.approx(b.mass, rel=1e-15)
    assert a.source == "<string>"


def test_icub_loads_its_inertias_printed_a_rounding_below_zero():
    """icub's r_hip_2 declares 0.526 kg with the inertia diagonal (-5.4e-20, -5.4e-20, 0),
    which Pinocchio refuses (RuntimeError): a rounding below zero is read as zero; a clearly
    negative one is a ModelError naming the link."""
    h = hm.load("icub")
    assert h.mass == pytest.approx(28.35, abs=0.01)
    from humanoid.data import body_path

    text = body_path("adult_male").read_text()
    link = text.index("<inertia ", text.index("<inertial>"))
    bad = text[:link] + text[link:].replace('ixx="', 'ixx="-1', 1)
    with pytest.raises(hm.ModelError, match="link '.*': inertia is not positive semi-definite"):
        hm.load(bad)


def test_cli_info_without_a_name_is_an_error(capsys):
    """``humanoid info ""``: the usage error, not an AttributeError."""
    from humanoid.cli import main

    assert main(["info", ""]) == 2
    assert "no model named (got '')" in capsys.readouterr().err


def test_load_example_shortcut():
    h = hm.load_example("talos")
    assert h.feet == ("left_sole_link", "right_sole_link")
    assert "talos" in hm.example_robot_names() and "human" in hm.example_robot_names()
    with pytest.raises(hm.ModelError, match=r"unknown example-robot-data robot 'robby'.*talos"):
        hm.load_example("robby")


def test_feet_given_by_the_caller():
    path, _ = example_robot_path("human")
    h = hm.load(path, feet=("left_foot", "right_foot"))
    assert h.feet == ("left_sole", "right_sole")
    with pytest.raises(hm.ModelError, match=r"no frame 'left_paw'.*frames: .*left_foot"):
        hm.load(path, feet=("left_paw", "right_foot"))


def _strip_feet(text: str) -> str:
    for word, other in (("foot", "paw"), ("sole", "pad"), ("ankle", "hock")):
        text = text.replace(word, other)
    return text


def test_no_identifiable_feet_names_candidates(male_urdf):
    message = r"cannot identify the left foot.*candidates \(leaf links\): left_toes"
    with pytest.raises(hm.ModelError, match=message):
        hm.load(_strip_feet(male_urdf))


def test_bad_ball_joint_mode(male_urdf):
    with pytest.raises(
        hm.ModelError,
        match="ball_joints: unknown ball-joint mode 'matrix': must be quaternion or euler",
    ):
        hm.load(male_urdf, ball_joints="matrix")


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace("</robot>", ""), r"<string>: malformed URDF XML"),
        (lambda t: "<robot_x/>", r"root element is <robot_x>"),
        (
            lambda t: re.sub(r'(<link name="left_thigh">\s*<inertial>\s*<origin[^>]*/>\s*'
                             r'<mass value=")[^"]*', r"\g<1>-1.0", t),
            r"link 'left_thigh': mass must be finite, >= 0 and <= 1e9 kg, got -1.0",
        ),
        (
            lambda t: re.sub(r'(<link name="head">\s*<inertial>\s*<origin[^>]*/>\s*'
                             r'<mass value="[^"]*"/>\s*<inertia ixx=")[^"]*', r"\g<1>-0.5", t),
            r"link 'head': inertia is not positive semi-definite",
        ),
        (
            lambda t: t.replace(
                '<box size="', '<mesh filename="package://nowhere/foot.stl"/><box size="', 1
            ),
            r"link 'pelvis': mesh 'package://nowhere/foot.stl' not found",
        ),
    ],
)  # fmt: skip
def test_malformed_urdf_is_a_clear_error(male_urdf, edit, message):
    with pytest.raises(hm.ModelError, match=message):
        hm.load(edit(male_urdf))


def test_missing_file_and_bad_types(tmp_path):
    with pytest.raises(hm.ModelError, match="URDF file not found: .*nothing.urdf"):
        hm.load(tmp_path / "nothing.urdf")
    with pytest.raises(hm.ModelError, match="expected a URDF path or URDF text, got int"):
        hm.load(42)
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'>")
    with pytest.raises(hm.ModelError, match=r"bad.urdf: malformed URDF XML"):
        hm.load(bad)


def test_a_users_urdf_with_relative_meshes(tmp_path):
    """A URDF with a relative mesh path loads from its own folder (meshes of erd's human)."""
    path, package = example_robot_path("human")
    text = path.read_text().replace(
        "package://example-robot-data/robots/human_description/meshes/", "meshes/"
    )
    (tmp_path / "meshes").symlink_to(path.parent.parent / "meshes")
    mine = tmp_path / "person.urdf"
    mine.write_text(text)
    h = hm.load(mine)
    assert h.visual_model.ngeoms == get_model("human", "quaternion").visual_model.ngeoms > 0


def test_shipped_models_equal_the_builder():
    """The shipped bodies are what scripts/make_models.py writes with the current builder."""
    expected = {
        "adult_male.urdf": hm.BodyParameters(1.75, 75.0, "male"),
        "adult_female.urdf": hm.BodyParameters(1.62, 62.0, "female"),
    }
    for name, params in expected.items():
        assert (BODIES / name).read_text() == hm.build_urdf(params), (
            f"{name} is stale: run `make models`"
        )


@pytest.mark.parametrize(("name", "mode"), [("human", "quaternion"), ("talos", "quaternion"),
                                            ("male", "quaternion")])  # fmt: skip
def test_sole_points_inner_is_medial_and_heel_is_behind(name, mode):
    """Generated and written sole points alike: standing, each foot's inner points lie toward
    the body's midline (y = 0) from its outer points, and the heels behind the toes."""
    h = get_model(name, mode)
    m, data = h.model, h.model.createData()
    pin.framesForwardKinematics(m, data, h.standing_configuration())
    for side in ("left", "right"):
        corners = ("heel_inner", "heel_outer", "toe_inner", "toe_outer")
        assert h.contact_points[side] == tuple(f"{side}_{c}" for c in corners)
        pts = {c: data.oMf[m.getFrameId(f"{side}_{c}")].translation for c in corners}
        for end in ("heel", "toe"):
            assert abs(pts[f"{end}_inner"][1]) < abs(pts[f"{end}_outer"][1]) - 0.01, (side, end)
        for edge in ("inner", "outer"):
            assert pts[f"heel_{edge}"][0] < pts[f"toe_{edge}"][0] - 0.05, (side, edge)


def test_a_joint_that_moves_no_mass_is_refused_by_name():
    """romeo's fingers and hands are massless leaves: M(q) is singular. The error names the
    joints and links and says how to merge them."""
    with pytest.raises(hm.ModelError, match=r"24 joints move no mass.*LHand.*LFinger11Link.*merge"):
        hm.load_example("romeo")


def test_massless_joints_merge_into_their_parents_and_the_body_stands():
    """massless='merge' locks them: M is positive definite, the mass is the URDF's, the
    geometry follows, and romeo stands on welded feet under the posture hold for 1 s."""
    from humanoid.scene import Contact, Controller, Effects, Scene

    h = hm.load_example("romeo", massless="merge")
    path, _ = example_robot_path("romeo")
    full = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    assert h.nv == full.nv - 24
    assert h.mass == pytest.approx(sum(i.mass for i in full.inertias), rel=1e-12)
    q = h.standing_configuration()
    M = hm.mass_matrix(h, q)
    assert np.linalg.eigvalsh(M).min() > 1e-6
    assert h.model.existFrame("LFinger21Link")  # the merged links stay as frames
    scene = Scene(body=str(path), massless="merge", duration=1.0,
                  effects=Effects(contacts=(Contact("left"), Contact("right"))),
                  controller=Controller("posture", frequency=4.0))  # fmt: skip
    traj = hm.simulate(scene, humanoid=h, quiet=True)
    assert traj.status == "completed"
    assert abs(traj.q[-1, 2] - traj.q[0, 2]) < 1e-6
    weight = traj.forces["left"][-1, 2] + traj.forces["right"][-1, 2]
    assert weight == pytest.approx(h.mass * 9.81, rel=1e-6)


def test_a_body_without_mass_is_refused(male_urdf):
    text = re.sub(r"<inertial>.*?</inertial>", "", male_urdf, flags=re.S)
    with pytest.raises(hm.ModelError, match="has no mass"):
        hm.load(text)


def test_bodies_and_robots_load_by_name():
    male = hm.load("adult_male")
    assert male.source == str(BODIES / "adult_male.urdf")
    assert male.mass == pytest.approx(75.0, abs=1e-9)
    assert hm.load("adult_female").mass == pytest.approx(62.0, abs=1e-9)
    assert hm.load("talos").recipe["example"] == "talos"
    with pytest.raises(hm.ModelError, match="adult_female.*talos"):
        hm.load("adult_mal")  # the message lists the names that would have worked


def test_a_body_loads_again_from_its_recipe_without_its_file(tmp_path):
    from humanoid.model import load_recipe

    urdf = tmp_path / "me.urdf"
    urdf.write_text(hm.build_urdf(hm.BodyParameters(1.9, 90.0, "male")))
    h = hm.load(urdf, ball_joints="euler")
    urdf.unlink()
    again = load_recipe(h.recipe)
    assert again.mass == pytest.approx(90.0, abs=1e-9)
    assert again.ball_joints == "euler" and again.model.nq == h.model.nq
    for bad in ({}, {"urdf": 3}, "talos", {"example": "robby"}):
        with pytest.raises(hm.ModelError):
            load_recipe(bad)


def test_a_humanoid_without_foot_geometry_loads_and_says_how_to_add_contacts():
    """example-robot-data's simple_humanoid has no geometry: it loads (contact points are
    needed only by contacts), stands with its lowest frame on the floor, and a scene that asks
    for a foot contact gets an error saying how to give the points."""
    h = hm.load("simple_humanoid")
    assert h.contact_points == {"left": (), "right": ()}
    q = h.standing_configuration()
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, q)
    assert min(f.translation[2] for f in data.oMf) == pytest.approx(0.0, abs=1e-12)
    scene = hm.Scene(body="simple_humanoid", duration=0.01,
                     effects=hm.scene.Effects(contacts=(hm.scene.Contact("left"),)))  # fmt: skip
    with pytest.raises(hm.ModelError, match=r"left_heel_inner.*frames .*feet=\(left, right\)"):
        hm.simulate(scene, quiet=True)


def test_a_robot_stands_in_its_srdf_posture():
    """example-robot-data's Talos starts from its SRDF's half_sitting (knees at 0.859395 rad, the
    value in talos.srdf), soles flat on the floor; the body's own postures come from an SRDF
    the caller gives (by hinge name, through the fused ball joints too); a body with none
    stands upright; a posture it does not have is an error naming the ones it has."""
    talos = hm.load("talos")
    assert talos.reference_posture == "half_sitting"
    q = talos.reference_configuration()
    m, d = talos.model, talos.model.createData()
    knee = m.joints[m.getJointId("leg_left_4_joint")].idx_q
    assert q[knee] == pytest.approx(0.859395, abs=1e-9)
    pin.framesForwardKinematics(m, d, q)
    for side in ("left", "right"):
        z = [d.oMf[m.getFrameId(n)].translation[2] for n in talos.contact_points[side]]
        # on the floor, flat to the SRDF's own rounding (its hip, knee and ankle pitches sum
        # to -0.0004 rad: the heels 0.23 mm up)
        assert min(z) == pytest.approx(0.0, abs=1e-9) and max(z) < 3e-4, z
    assert q[2] < talos.standing_configuration()[2] - 0.03  # half sitting: the pelvis lower
    with pytest.raises(hm.ModelError, match="no posture 'crouch'.*half_sitting"):
        talos.reference_configuration("crouch")

    male = hm.load("adult_male")
    assert male.postures == {} and male.reference_posture is None
    assert np.array_equal(male.reference_configuration(), male.standing_configuration())
    srdf = ('<robot name="b"><group_state name="lunge" group="all">'
            '<joint name="right_knee" value="0.5"/><joint name="left_hip_flexion" value="0.3"/>'
            '<joint name="no_such_joint" value="1"/></group_state></robot>')  # fmt: skip
    h = hm.load("adult_male", srdf=srdf)
    lunge = h.reference_configuration("lunge")
    qe, _ = h.to_euler(lunge)
    em = h.euler_model
    for name, value in (("right_knee", 0.5), ("left_hip_flexion", 0.3)):
        assert qe[em.joints[em.getJointId(name)].idx_q] == pytest.approx(value, abs=1e-9)
    from humanoid.model import load_recipe

    assert set(load_recipe(h.recipe).postures) == {"lunge"}  # a saved run keeps it
    with pytest.raises(hm.ModelError, match="'right_knee' has value 'bent'"):
        hm.load("adult_male", srdf=srdf.replace('"0.5"', '"bent"'))
    with pytest.raises(hm.ModelError, match="SRDF file not found"):
        hm.load("adult_male", srdf="missing.srdf")
