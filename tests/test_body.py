"""The de Leva body as URDF: parsing, masses, inertias, mirror symmetry, standing pose, limits.

The structure checked here is the one-piece foot's (``toes=False``); ``test_toes.py`` checks
the foot with toes (the default), and the mirror symmetry runs on both."""

from __future__ import annotations

import functools
import io
import itertools
import math

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy
from hypothesis import given, settings
from hypothesis import strategies as st
from lxml import etree

import humanoid
from humanoid import body
from humanoid.anthropometry import BodyParameters, body_dimensions

SIDES = ("left", "right")
CORNERS = ("heel_inner", "heel_outer", "toe_inner", "toe_outer")
S = np.diag([1.0, -1.0, 1.0])  # reflection through the y = 0 (sagittal) plane
ATOL = 1e-12  # [m], [-] or [kg m^2]: tolerance of exact geometric identities

# (height [m], mass [kg], sex, measured segment lengths)
BODIES = [
    (1.75, 75.0, "male", {}),
    (1.62, 62.0, "female", {}),
    (1.10, 20.0, "female", {}),
    (2.05, 120.0, "male", {}),
    (1.80, 80.0, "male", {"thigh": 0.5, "ankle_height": 0.08}),
]
BODY_IDS = [f"{s}-{h}m-{m}kg" + ("-measured" if x else "") for h, m, s, x in BODIES]

# Links that carry no mass: the intermediate links of the ball joints and of the two-hinge
# wrists and ankles, and the fixed sole and contact-point links.
MASSLESS = {
    f"{prefix}_{motion}_link"
    for prefix, motions in [
        ("lumbar", ("flexion", "bending")),
        ("thoracic", ("flexion", "bending")),
        ("neck", ("flexion", "bending")),
    ]
    for motion in motions
} | {
    name
    for side in SIDES
    for name in (
        f"{side}_hip_flexion_link",
        f"{side}_hip_adduction_link",
        f"{side}_shoulder_flexion_link",
        f"{side}_shoulder_abduction_link",
        f"{side}_wrist_flexion_link",
        f"{side}_ankle_flexion_link",
        f"{side}_sole",
        *(f"{side}_{c}" for c in CORNERS),
    )
}
MASSIVE = {"pelvis", "abdomen", "thorax", "head"} | {
    f"{side}_{seg}"
    for side in SIDES
    for seg in ("upper_arm", "forearm", "hand", "thigh", "shank", "foot")
}


def _params(h, m, sex, lengths=None, toes=False) -> BodyParameters:
    return BodyParameters(h, m, sex, segment_lengths=dict(lengths or {}), toes=toes)


@functools.cache
def _xml(h, m, sex, lengths=(), toes=False) -> str:
    return humanoid.build_urdf(_params(h, m, sex, dict(lengths), toes))


def _key(h, m, sex, lengths, toes=False):
    return (h, m, sex, tuple(sorted(lengths.items())), toes)


@functools.cache
def _robot(key) -> yourdfpy.Robot:
    urdf = yourdfpy.URDF.load(io.StringIO(_xml(*key)), build_scene_graph=False, load_meshes=False)
    return urdf.robot


@functools.cache
def _loaded(key, mode) -> humanoid.Humanoid:
    return humanoid.load(_xml(*key), ball_joints=mode)


def _pin_model(xml: str) -> pin.Model:
    return pin.buildModelFromXML(xml, pin.JointModelFreeFlyer())


def _mirror_name(name: str) -> str:
    return "right_" + name[len("left_") :] if name.startswith("left_") else name


# --- parsing -----------------------------------------------------------------------------------


@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_urdf_parses_with_yourdfpy(h, m, sex, lengths, tmp_path):
    xml = _xml(*_key(h, m, sex, lengths))
    from_string = yourdfpy.URDF.load(io.StringIO(xml), load_meshes=False)
    path = humanoid.write_urdf(_params(h, m, sex, lengths), tmp_path / "body.urdf")
    from_file = yourdfpy.URDF.load(str(path), load_meshes=False)
    for urdf in (from_string, from_file):
        assert urdf.validate()
        assert urdf.robot.name == f"humanoid_{sex}"
        assert urdf.base_link == "pelvis"
        joints = urdf.robot.joints
        # 33 joint DoF (module docstring): 3 x 3 spine/neck + 2 x (3 + 1 + 2 + 3 + 1 + 2)
        assert sum(j.type == "revolute" for j in joints) == 33
        assert sum(j.type == "fixed" for j in joints) == 10  # sole + 4 corners, per foot
        assert {j.type for j in joints} == {"revolute", "fixed"}
        assert len(urdf.robot.links) == len(joints) + 1  # a tree
        assert {link.name for link in urdf.robot.links} == MASSIVE | MASSLESS


@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_urdf_parses_with_pinocchio(h, m, sex, lengths):
    model = _pin_model(_xml(*_key(h, m, sex, lengths)))
    assert model.nq == 7 + 33
    assert model.nv == 6 + 33
    assert model.njoints == 1 + 1 + 33  # universe, free flyer, hinges
    assert model.names[1] == "root_joint"
    for side in SIDES:
        for name in (f"{side}_sole", *(f"{side}_{c}" for c in CORNERS)):
            assert model.existFrame(name), name


# --- masses and inertias -----------------------------------------------------------------------


@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_total_mass_in_pinocchio(h, m, sex, lengths):
    model = _pin_model(_xml(*_key(h, m, sex, lengths)))
    total = pin.computeTotalMass(model)
    assert math.isclose(total, m, rel_tol=1e-9), f"total mass {total!r} kg, input {m!r} kg"


@settings(max_examples=20, derandomize=True, deadline=None)
@given(
    h=st.floats(0.5, 2.5),
    m=st.floats(10.0, 300.0),
    sex=st.sampled_from(("male", "female")),
)
def test_total_mass_in_pinocchio_for_any_body(h, m, sex):
    model = _pin_model(humanoid.build_urdf(BodyParameters(h, m, sex)))
    total = pin.computeTotalMass(model)
    assert math.isclose(total, m, rel_tol=1e-9), f"total mass {total!r} kg, input {m!r} kg"


@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_link_inertias_are_physical(h, m, sex, lengths):
    for link in _robot(_key(h, m, sex, lengths)).links:
        if link.inertial is None:
            continue
        I = np.asarray(link.inertial.inertia, dtype=float)
        assert link.inertial.mass > 0.0, link.name
        np.testing.assert_array_equal(I, I.T, err_msg=link.name)
        eig = np.linalg.eigvalsh(I)
        assert eig[0] > 0.0, f"{link.name}: inertia not positive definite, eigenvalues {eig}"
        for a, b, c in itertools.permutations(eig):
            assert a + b >= c * (1.0 - 1e-12), (
                f"{link.name}: principal moments {eig} break the triangle inequality"
            )


@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_massless_links_are_exactly_the_intermediate_and_contact_links(h, m, sex, lengths):
    links = _robot(_key(h, m, sex, lengths)).links
    massless = {link.name for link in links if link.inertial is None}
    assert massless == MASSLESS
    for link in links:
        if link.inertial is not None:
            assert link.inertial.mass > 0.0, link.name
            assert np.any(np.asarray(link.inertial.inertia) != 0.0), link.name
    # the massless links carry no geometry
    for link in links:
        if link.name in MASSLESS:
            assert not link.visuals and not link.collisions, link.name


# --- left/right symmetry -----------------------------------------------------------------------


@pytest.mark.parametrize("toes", [False, True], ids=["foot", "toes"])
@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_right_joints_mirror_the_left_ones(h, m, sex, lengths, toes):
    joints = {j.name: j for j in _robot(_key(h, m, sex, lengths, toes)).joints}
    left = [n for n in joints if n.startswith("left_")]
    right = [n for n in joints if n.startswith("right_")]
    # the toes add the mtp hinge, the toes' sole and the two metatarsal-head points
    assert len(left) == (21 if toes else 17), sorted(left)
    assert sorted(map(_mirror_name, left)) == sorted(right)
    for name in left:
        jl, jr = joints[name], joints[_mirror_name(name)]
        assert jr.type == jl.type, name
        assert jr.parent == _mirror_name(jl.parent), name
        assert jr.child == _mirror_name(jl.child), name
        np.testing.assert_allclose(
            jr.origin[:3, 3], S @ jl.origin[:3, 3], rtol=0, atol=ATOL, err_msg=name
        )
        np.testing.assert_allclose(
            jr.origin[:3, :3], S @ jl.origin[:3, :3] @ S, rtol=0, atol=ATOL, err_msg=name
        )
        if jl.type != "revolute":
            continue
        ax = np.asarray(jl.axis, dtype=float)
        np.testing.assert_allclose(
            jr.axis, [-ax[0], ax[1], -ax[2]], rtol=0, atol=ATOL, err_msg=name
        )
        for attr in ("lower", "upper", "effort", "velocity"):
            assert getattr(jr.limit, attr) == getattr(jl.limit, attr), f"{name}.{attr}"
    # the contact corners are mirrored by name, not only by position: inner is medial
    for corner in CORNERS:
        yl = joints[f"left_{corner}_joint"].origin[1, 3]
        assert (yl < 0) == corner.endswith("inner"), corner


@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_right_links_mirror_the_left_ones(h, m, sex, lengths):
    links = {link.name: link for link in _robot(_key(h, m, sex, lengths)).links}
    left = [n for n in links if n.startswith("left_")]
    right = [n for n in links if n.startswith("right_")]
    assert sorted(map(_mirror_name, left)) == sorted(right)
    for name in left:
        il, ir = links[name].inertial, links[_mirror_name(name)].inertial
        assert (il is None) == (ir is None), name
        if il is None:
            continue
        assert ir.mass == il.mass, name
        np.testing.assert_allclose(
            ir.origin[:3, 3], S @ il.origin[:3, 3], rtol=0, atol=ATOL, err_msg=name
        )
        np.testing.assert_allclose(
            ir.origin[:3, :3], S @ il.origin[:3, :3] @ S, rtol=0, atol=ATOL, err_msg=name
        )
        np.testing.assert_allclose(ir.inertia, S @ il.inertia @ S, rtol=1e-12, atol=0, err_msg=name)


# --- standing ----------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["euler", "quaternion"])
@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_standing_configuration(h, m, sex, lengths, mode):
    hum = _loaded(_key(h, m, sex, lengths), mode)
    assert hum.feet == ("left_sole", "right_sole")
    assert hum.contact_points == {s: tuple(f"{s}_{c}" for c in CORNERS) for s in SIDES}
    q = hum.standing_configuration()
    model = hum.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    names = [n for side in SIDES for n in hum.contact_points[side]] + list(hum.feet)
    assert len(names) == 10
    for name in names:
        z = data.oMf[model.getFrameId(name)].translation[2]
        assert abs(z) <= 1e-12, f"{name} at z = {z!r} m in the standing configuration"
    com = pin.centerOfMass(model, data, q)
    ratio = com[2] / h
    assert 0.53 <= ratio <= 0.58, f"standing CoM at {ratio:.4f} x height ({com[2]:.4f} m)"
    assert abs(com[1]) <= 1e-12, f"CoM off the sagittal plane by {com[1]!r} m"
    # the top of the head (vertex) is at the stature: the chain closes
    top = hum.standing_height()
    assert math.isclose(top, h, rel_tol=1e-9), f"vertex at {top!r} m, height {h!r} m"


def test_euler_and_quaternion_models_stand_alike():
    key = _key(*BODIES[0])
    coms = []
    for mode in ("euler", "quaternion"):
        hum = _loaded(key, mode)
        coms.append(
            pin.centerOfMass(hum.model, hum.model.createData(), hum.standing_configuration())
        )
    np.testing.assert_allclose(coms[0], coms[1], rtol=0, atol=1e-12)


# --- joints ------------------------------------------------------------------------------------


@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_revolute_joint_limits(h, m, sex, lengths):
    for j in _robot(_key(h, m, sex, lengths)).joints:
        if j.type != "revolute":
            continue
        lim = j.limit
        assert lim is not None, j.name
        assert lim.lower < lim.upper, f"{j.name}: empty range [{lim.lower}, {lim.upper}]"
        assert lim.lower <= 0.0 <= lim.upper, f"{j.name}: 0 outside [{lim.lower}, {lim.upper}]"
        assert lim.effort > 0.0, j.name
        assert lim.velocity > 0.0, j.name
        assert np.isclose(np.linalg.norm(j.axis), 1.0, rtol=0, atol=ATOL), j.name


def test_knee_and_elbow_limits_in_degrees():
    joints = {j.name: j for j in _robot(_key(*BODIES[0])).joints}
    for side in SIDES:
        knee, elbow = joints[f"{side}_knee"].limit, joints[f"{side}_elbow"].limit
        assert (knee.lower, knee.upper) == (0.0, pytest.approx(math.radians(140.0), abs=1e-15))
        assert (elbow.lower, elbow.upper) == (0.0, pytest.approx(math.radians(145.0), abs=1e-15))


def test_joint_ranges_have_sources():
    assert len(body.JOINT_RANGES) == 22  # 21 and the toes body's mtp
    for name, rng in body.JOINT_RANGES.items():
        assert isinstance(rng.source, str) and rng.source.strip(), name
        assert rng.lower < rng.upper, name


def test_every_revolute_joint_uses_a_joint_range():
    joints = _robot(_key(*BODIES[1])).joints
    for j in joints:
        if j.type != "revolute":
            continue
        kind = j.name.removeprefix("left_").removeprefix("right_")
        rng = body.JOINT_RANGES[kind]
        assert j.limit.lower == pytest.approx(math.radians(rng.lower), abs=1e-15), j.name
        assert j.limit.upper == pytest.approx(math.radians(rng.upper), abs=1e-15), j.name


# Positive angles are anatomical on both sides (module docstring). Each case: joint (without
# side), angle [rad], other joints set first, the moving point, and the direction it must move
# for the LEFT side in the upright frame (x forward, y left, z up); the right side mirrors y.
SIGN_CASES = [
    ("hip_flexion", {}, ("frame", "{s}_shank"), (1, 0, 0)),  # knee forward
    ("hip_adduction", {}, ("frame", "{s}_shank"), (0, -1, 0)),  # knee toward the midline
    ("hip_rotation", {}, ("frame", "{s}_toe_outer"), (0, -1, 0)),  # toes turn in (internal)
    ("knee", {}, ("frame", "{s}_foot"), (-1, 0, 0)),  # ankle goes back
    ("ankle_flexion", {}, ("frame", "{s}_toe_outer"), (0, 0, 1)),  # dorsiflexion: toes up
    ("ankle_inversion", {}, ("frame", "{s}_heel_inner"), (0, 0, 1)),  # medial border rises
    ("ankle_inversion", {}, ("frame", "{s}_heel_outer"), (0, 0, -1)),  # lateral border drops
    ("shoulder_flexion", {}, ("frame", "{s}_forearm"), (1, 0, 0)),  # elbow forward
    ("shoulder_abduction", {}, ("frame", "{s}_forearm"), (0, 1, 0)),  # elbow out
    # with the elbow flexed 90 deg, internal rotation swings the hand to the midline
    ("shoulder_rotation", {"{s}_elbow": math.pi / 2}, ("frame", "{s}_hand"), (0, -1, 0)),
    ("elbow", {}, ("frame", "{s}_hand"), (1, 0, 0)),  # wrist forward
    # palms face the thighs, thumbs forward: flexion toward the palm (medial), radial
    # deviation toward the thumb (forward)
    ("wrist_flexion", {}, ("com", "{s}_hand"), (0, -1, 0)),
    ("wrist_deviation", {}, ("com", "{s}_hand"), (1, 0, 0)),
]
SPINE_CASES = [
    ("lumbar_flexion", ("com", "head"), (1, 0, 0)),
    ("lumbar_bending", ("com", "head"), (0, 1, 0)),  # bends to the left
    ("lumbar_rotation", ("frame", "left_upper_arm"), (-1, 0, 0)),  # turns to the left
    ("thoracic_flexion", ("com", "head"), (1, 0, 0)),
    ("thoracic_bending", ("com", "head"), (0, 1, 0)),
    ("thoracic_rotation", ("frame", "right_upper_arm"), (1, 0, 0)),
    ("neck_flexion", ("com", "head"), (1, 0, 0)),
    ("neck_bending", ("com", "head"), (0, 1, 0)),
]


def _point(model, data, q, spec):
    kind, name = spec
    pin.framesForwardKinematics(model, data, q)
    frame = model.frames[model.getFrameId(name)]
    if kind == "frame":
        return data.oMf[model.getFrameId(name)].translation.copy()
    jid = frame.parentJoint
    return data.oMi[jid].act(model.inertias[jid].lever)


def _displacement(model, joint, angle, preset, spec):
    data = model.createData()
    q0 = pin.neutral(model)
    for name, value in preset.items():
        q0[model.joints[model.getJointId(name)].idx_q] = value
    q1 = q0.copy()
    q1[model.joints[model.getJointId(joint)].idx_q] = angle
    return _point(model, data, q1, spec) - _point(model, data, q0, spec)


@pytest.mark.parametrize("side", SIDES)
@pytest.mark.parametrize(("kind", "preset", "spec", "direction"), SIGN_CASES)
def test_positive_limb_angles_are_anatomical(side, kind, preset, spec, direction):
    model = _pin_model(_xml(*_key(*BODIES[0])))
    d = np.array(direction, dtype=float)
    if side == "right":
        d = S @ d
    preset = {k.format(s=side): v for k, v in preset.items()}
    spec = (spec[0], spec[1].format(s=side))
    moved = _displacement(model, f"{side}_{kind}", 0.3, preset, spec)
    along = float(moved @ d)
    assert along > 1e-3, f"{side}_{kind} +0.3 rad moves {spec[1]} by {moved} m"


@pytest.mark.parametrize(("joint", "spec", "direction"), SPINE_CASES)
def test_positive_spine_angles_are_anatomical(joint, spec, direction):
    model = _pin_model(_xml(*_key(*BODIES[0])))
    moved = _displacement(model, joint, 0.3, {}, spec)
    along = float(moved @ np.array(direction, dtype=float))
    assert along > 1e-3, f"{joint} +0.3 rad moves {spec[1]} by {moved} m"


# --- feet and contacts -------------------------------------------------------------------------


@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_contact_frames_and_sole_box(h, m, sex, lengths):
    key = _key(h, m, sex, lengths)
    root = etree.fromstring(_xml(*key).encode())
    links = {link.get("name"): link for link in root.iter("link")}
    d = body_dimensions(_params(h, m, sex, lengths))
    for side in SIDES:
        for name in (f"{side}_sole", *(f"{side}_{c}" for c in CORNERS)):
            assert name in links, name
        boxes = links[f"{side}_foot"].findall("collision/geometry/box")
        assert len(boxes) == 1, f"{side}_foot has {len(boxes)} collision boxes"
        size = [float(v) for v in boxes[0].get("size").split()]
        np.testing.assert_allclose(
            size, [d["foot"], d["foot_width"], d["ankle_height"]], rtol=1e-12, atol=0
        )
    # in the standing pose the corners span the box's sole face and the sole frame is its centre
    hum = _loaded(key, "euler")
    model = hum.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, hum.standing_configuration())

    def at(name):
        return data.oMf[model.getFrameId(name)].translation

    for side in SIDES:
        c = {corner: at(f"{side}_{corner}") for corner in CORNERS}
        medial = -1.0 if side == "left" else 1.0  # toward y = 0
        for end in ("heel", "toe"):
            gap = c[f"{end}_inner"] - c[f"{end}_outer"]
            np.testing.assert_allclose(gap, [0, medial * d["foot_width"], 0], atol=ATOL, rtol=0)
        for edge in ("inner", "outer"):
            gap = c[f"toe_{edge}"] - c[f"heel_{edge}"]
            np.testing.assert_allclose(gap, [d["foot"], 0, 0], atol=ATOL, rtol=0)
        np.testing.assert_allclose(
            at(f"{side}_sole"), np.mean(list(c.values()), axis=0), atol=ATOL, rtol=0
        )
        # the ankle joint centre is ankle_height above the sole, a quarter foot from the heel
        ankle = at(f"{side}_foot")
        assert abs(ankle[2] - d["ankle_height"]) <= ATOL
        heel_x = c["heel_outer"][0]
        assert math.isclose(ankle[0] - heel_x, 0.25 * d["foot"], rel_tol=1e-9)


# --- writing -----------------------------------------------------------------------------------


@pytest.mark.parametrize(("h", "m", "sex", "lengths"), BODIES, ids=BODY_IDS)
def test_write_urdf_writes_build_urdf(h, m, sex, lengths, tmp_path):
    params = _params(h, m, sex, lengths)
    target = tmp_path / "new" / "folder" / "body.urdf"
    path = humanoid.write_urdf(params, target)
    assert path == target
    assert path.read_text(encoding="ascii") == humanoid.build_urdf(params)
    assert humanoid.build_urdf(params) == humanoid.build_urdf(params)  # deterministic
    for k, v in sorted(lengths.items()):
        assert f"{k} {v} m" in path.read_text()


@pytest.mark.parametrize(("height", "mass", "sex"), [(1.62, 58.0, "female"), (1.91, 95.0, "male")])
def test_built_trunk_segments_put_their_com_from_de_levas_upper_landmark(height, mass, sex):
    """The builder's own output (not the shipped files): de Leva measures the trunk segments'
    and the head's CoM from their upper landmark (pelvis and abdomen from the landmark above,
    upper trunk from CERV, head from VERT, the top of the head), so in the standing body each
    CoM lies com_fraction x length below that landmark: the next joint up, or the head's top.
    Measured from the wrong end, the pelvis's CoM moves by (1 - 2 x 0.61) x 0.145 L."""
    from humanoid.anthropometry import segments

    params = BodyParameters(height, mass, sex)
    seg = segments(params)
    h = humanoid.load(body.build_urdf(params))
    model, data = h.model, h.model.createData()
    pin.forwardKinematics(model, data, h.standing_configuration())

    def joint_of(link):
        return model.frames[model.getFrameId(link)].parentJoint

    def com(link):
        j = joint_of(link)
        return data.oMi[j].act(model.inertias[j].lever)

    above = {"pelvis": "abdomen", "abdomen": "thorax", "thorax": "head"}
    for name in ("pelvis", "abdomen", "thorax", "head"):
        s = seg[name]
        if name == "head":
            top = data.oMi[joint_of("head")].translation + np.array([0.0, 0.0, s.length])
        else:
            top = data.oMi[joint_of(above[name])].translation
        c = com(name)
        assert c[2] < top[2]
        assert top[2] - c[2] == pytest.approx(s.com_fraction * s.length, abs=1e-9), name


def test_peak_torques_and_passive_damping_scale_with_the_body_mass():
    """A 100 kg body's joint torque limits and passive damping are twice a 50 kg one's, its
    speed limits and ranges the same (planted bugs left them at the 75 kg adult's)."""
    light, heavy = (_robot(_key(1.75, m, "male", {}, toes=True)) for m in (50.0, 100.0))
    damped = 0
    for jl, jh in zip(light.joints, heavy.joints, strict=True):
        assert jl.name == jh.name
        if jl.type != "revolute":
            continue
        assert jh.limit.effort == pytest.approx(2.0 * jl.limit.effort, rel=1e-12), jl.name
        assert jh.limit.velocity == jl.limit.velocity, jl.name
        assert (jh.limit.lower, jh.limit.upper) == (jl.limit.lower, jl.limit.upper), jl.name
        if jl.dynamics is not None and float(jl.dynamics.damping):  # (parsed as text)
            damped += 1
            assert float(jh.dynamics.damping) == pytest.approx(2.0 * float(jl.dynamics.damping),
                                                              rel=1e-12)  # fmt: skip
    assert damped > 0
