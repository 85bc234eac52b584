"""The second fuzz run's findings, reproduced: every bad motion file, marker set, map, study or
option ends in a typed error naming the file and the field (or line), never a hang, an
untyped exception or a silently wrong result."""

from __future__ import annotations

import io
import re
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from conftest import get_model

import humanoid as hm
from humanoid.cli import main
from humanoid.errors import HumanoidError
from humanoid.motion.bvh import read_bvh
from humanoid.motion.coordinates import configurations, coordinates_table, read_map
from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.inverse_dynamics import derivatives
from humanoid.motion.markers import Marker, MarkerTrajectories, read_c3d, read_markers, read_trc
from humanoid.motion.storage import MotionFileError, read_storage, write_storage
from humanoid.study.spec import load_study

TRIALS = Path(hm.__file__).parent / "data" / "trials"
TRC = (TRIALS / "subject01_walk1.trc").read_text().splitlines()[:30]
GRF = (TRIALS / "subject01_walk1_grf.mot").read_text().splitlines()[:30]

BVH = """HIERARCHY
ROOT Hips
{
 OFFSET 0 0 0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT LeftUpLeg
 {
  OFFSET 10 -5 0
  CHANNELS 3 Zrotation Xrotation Yrotation
  End Site
  {
   OFFSET 0 -90 0
  }
 }
}
MOTION
Frames: 2
Frame Time: 0.0333
0 90 0 0 0 0 0 0 0
0 90 0 0 0 0 0 0 0
"""


def _cli(argv) -> tuple[int, str]:
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        code = main(argv)
    return code, err.getvalue()


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("0.0333", "inf", r"'Frame Time: inf' \[s\]: a positive, finite time"),
        ("0.0333", "nan", r"'Frame Time: nan'"),
        ("0.0333", "1e-12", r"at most 100000 Hz"),
        ("Frames: 2", "Frames: abc", r"'Frames: abc' is not a number"),
        ("ROOT Hips", "JOINT Hips", r":2: JOINT Hips: the hierarchy has one ROOT"),
        ("CHANNELS 3 Zrotation", "CHANNELS 3 Wrotation", r":9: LeftUpLeg: unknown channel"),
        ("0 90 0 0 0 0 0 0 0\n0 90", "0 abc 0 0 0 0 0 0 0\n0 90", r"frame 1: not a number"),
        ("0 90 0 0 0 0 0 0 0\n0 90", "0 1e300 0 0 0 0 0 0 0\n0 90", r"frame 1, channel 2"),
    ],
)  # fmt: skip
def test_a_bad_bvh_is_a_motion_file_error(tmp_path, old, new, message):
    path = tmp_path / "bad.bvh"
    path.write_text(BVH.replace(old, new))
    with pytest.raises(MotionFileError, match=message):
        read_bvh(path)


def _trc(tmp_path, edit) -> Path:
    lines = list(TRC)
    edit(lines)
    path = tmp_path / "bad.trc"
    path.write_text("\n".join(lines) + "\n")
    return path


def _cell(row: int, old: str, new: str):
    def edit(lines):
        assert old in lines[row]
        lines[row] = lines[row].replace(old, new, 1)

    return edit


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (_cell(2, "\t41\t", "\tabc\t"), r":3: NumMarkers='abc' is not a whole number"),
        (_cell(6, "617.247620", "1e300"), r"marker 'R.ASIS' at frame 1 .* beyond 1000 m"),
        (_cell(6, "617.247620", "inf"), r":7: time or a coordinate is not finite"),
        (_cell(7, "0.017000", "nan"), r":8: time or a coordinate is not finite"),
        (_cell(7, "0.017000", "0.000000"), r"time does not increase at frame 2"),
        (_cell(7, "0.017000", "1e-12"), r"a rate above 100000 Hz"),
        # millimetres labelled metres: the body 694 m up, fitted with a 578 m residual before
        (_cell(2, "\tmm\t", "\tm\t"), r"Units says m, which spreads the markers over 1.\d+e\+03 m"
                                      r" .* look like mm: set Units to mm"),
        (_cell(2, "\tmm\t", "\tcm\t"), r"look like mm"),
    ],
)  # fmt: skip
def test_a_bad_trc_is_a_motion_file_error(tmp_path, edit, message):
    with pytest.raises(MotionFileError, match=message):
        read_trc(_trc(tmp_path, edit))


def test_a_trc_in_metres_labelled_millimetres_is_refused(tmp_path):
    good = read_trc(_trc(tmp_path, lambda lines: None))
    markers = MarkerTrajectories(good.time, good.names, good.positions / 1000.0)
    path = tmp_path / "small.trc"
    hm.motion.markers.write_trc(path, markers)  # written as mm: numbers 1000 times too small
    with pytest.raises(MotionFileError, match=r"look like m: set Units to m"):
        read_trc(path)


def test_an_empty_c3d_unit_is_a_motion_file_error(tmp_path):
    import ezc3d

    c = ezc3d.c3d(str(TRIALS / "walking5.c3d"))
    c["parameters"]["POINT"]["UNITS"]["value"] = [""]
    c.write(str(tmp_path / "e.c3d"))
    with pytest.raises(MotionFileError, match=r"e.c3d: unknown POINT:UNITS ''"):
        read_c3d(tmp_path / "e.c3d")


@pytest.mark.parametrize(
    ("row", "old", "new", "message"),
    [
        (8, "0.0017", "nan", r"time is nan at sample 2"),
        (7, "101.5119767", "1e300", r"column 'ground_force_vx' is 1e\+300 at time 0 s"),
        (7, "101.5119767", "inf", r"column 'ground_force_vx' is inf"),
        (8, "0.0017", "1e-13", r"a rate above 100000 Hz"),
    ],
)
def test_a_bad_storage_file_is_a_motion_file_error(tmp_path, row, old, new, message):
    lines = list(GRF)
    assert old in lines[row]
    lines[row] = lines[row].replace(old, new, 1)
    path = tmp_path / "bad.mot"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MotionFileError, match=message):
        read_storage(path)


def _coordinates(tmp_path, degrees_flag):
    """A .mot of the male body with its right knee bent 60 deg, the numbers in degrees and
    the header's inDegrees as given (None: no such line)."""
    h = get_model("male", "quaternion")
    q = np.tile(h.standing_configuration(), (5, 1))
    q[:, h.model.joints[h.model.getJointId("right_knee")].idx_q] = np.radians(60.0)
    table = coordinates_table(h, np.arange(5) * 0.01, q)  # degrees
    table.in_degrees = degrees_flag
    path = write_storage(tmp_path / "c.mot", table)
    return h, read_storage(path)


def test_a_mot_in_degrees_flagged_radians_is_refused(tmp_path):
    """Before: the elbow at 233 deg and moments of 1.9e4 N m, without a word."""
    h, table = _coordinates(tmp_path, False)
    with pytest.raises(MotionFileError, match=r"column 'knee_angle_r' reaches \d+ deg \(read as "
                       r"radians\): the numbers look like degrees: set inDegrees=yes"):  # fmt: skip
        configurations(h, table)


@pytest.mark.parametrize("flag", [True, None])
def test_a_mot_in_degrees_reads_as_degrees_with_or_without_the_flag(tmp_path, flag):
    """OpenSim reads a Storage file without ``inDegrees`` as degrees, and so does the
    toolkit (a planted bug reading it as radians survived every other test)."""
    h, table = _coordinates(tmp_path, flag)
    assert table.in_degrees is flag
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, q, _ = configurations(h, table, floor=False)
    knee = q[:, h.model.joints[h.model.getJointId("right_knee")].idx_q]
    assert np.allclose(knee, np.radians(60.0))


MARKER = '[markers.A]\nframe = "pelvis"\noffset = [0, 0, 0]\n'


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ('anatomical = "false"', r"markers.A.anatomical must be true or false .* got 'false'"),
        ("fixed = 1", r"markers.A.fixed must be true or false"),
        ("weight = inf", r"markers.A: weight inf must be in \[0, 1e\+06\]"),
        ("weight = nan", r"markers.A: weight nan"),
        ("weight = -1.0", r"markers.A: weight -1"),
    ],
)
def test_a_bad_marker_set_is_refused_naming_the_key(tmp_path, extra, message):
    path = tmp_path / "set.toml"
    path.write_text(MARKER + extra + "\n")
    with pytest.raises(HumanoidError, match=message):
        read_markers(path)


def test_a_landmark_flag_given_as_a_string_is_refused(tmp_path):
    text = (Path(hm.__file__).parent / "data" / "markers" / "clusters.toml").read_text()
    path = tmp_path / "lm.toml"
    path.write_text(text.replace("anatomical = true", 'anatomical = "false"', 1))
    with pytest.raises(HumanoidError, match=r"landmarks.ASI.anatomical must be true or false"):
        hm.motion.markers.landmark_names(path)


MAP = """name = "x"
[root]
rotation = ["a", "b", "c"]
rotation_axes = ["z", "x", "y"]
translation = ["tx", "ty", "tz"]
translation_axes = ["x", "z", "-y"]
[joints.right_knee]
columns = ["knee_r"]
signs = [-1]
"""


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('rotation = ["a", "b", "c"]', 'rotation = "abc"', r"root.rotation must be a list of str"),
        ('rotation = ["a", "b", "c"]', "rotation = [1, 2, 3]", r"root.rotation must be a list"),
        ('rotation = ["a", "b", "c"]', 'rotation = ["a", "b"]', r"root.rotation must have 3"),
        ('rotation_axes = ["z", "x", "y"]', "rotation_axes = [1, 2, 3]", r"root.rotation_axes"),
        ('rotation_axes = ["z", "x", "y"]', 'rotation_axes = ["z", "x", "w"]', r"root: an axis"),
        ('translation = ["tx", "ty", "tz"]', "translation = {a = 1}", r"root.translation must"),
        ("signs = [-1]", 'signs = "x"', r"joints.right_knee.signs must be a list of finite"),
        ("signs = [-1]", "signs = [nan]", r"joints.right_knee.signs"),
        ('columns = ["knee_r"]', "columns = 5", r"joints.right_knee.columns must be a list"),
        ("signs = [-1]", 'signs = [-1]\njoints = "right_knee"', r"joints.right_knee.joints"),
    ],
)  # fmt: skip
def test_a_bad_map_is_refused_naming_the_key(tmp_path, old, new, message):
    assert old in MAP
    path = tmp_path / "map.toml"
    path.write_text(MAP.replace(old, new))
    with pytest.raises(HumanoidError, match=message):
        read_map(path)


@pytest.mark.parametrize(
    ("time", "message"),
    [
        (np.arange(7) * 0.1, r"7 times and 13 markers need positions of shape \(7, 13, 3\)"),
        (np.r_[np.nan, np.arange(9) * 0.1], r"time of frame 1 is nan"),
        (np.zeros(10), r"time does not increase at frame 2"),
    ],
)
def test_bad_keypoint_times_are_refused(tmp_path, time, message):
    path = tmp_path / "kp.npz"
    np.savez(path, points=np.random.default_rng(0).random((10, 17, 3)), time=time)
    code, err = _cli(["ik", str(path), "--layout", "coco17", "-o", str(tmp_path / "o.mot")])
    assert code == 2
    assert f"{path}: " in err
    assert len(re.findall(message, err)) == 1, err


@pytest.mark.parametrize("rate", ["nan", "0", "-30", "1e9"])
def test_a_bad_keypoint_rate_is_refused(tmp_path, rate):
    path = tmp_path / "kp.npy"
    np.save(path, np.zeros((4, 17, 3)))
    code, err = _cli(["ik", str(path), "--layout", "coco17", "--rate", rate, "-o",
                      str(tmp_path / "o.mot")])  # fmt: skip
    assert code == 2
    assert f"--rate {float(rate)}: a frame rate in (0, 100000] Hz" in err


def _standing_markers(n=4):
    h = get_model("male", "quaternion")
    marker_set = {k: v for k, v in hm.motion.markers.default_markers(h).items() if "." in k}
    q = np.tile(h.standing_configuration(), (n, 1))
    positions = hm.motion.markers.marker_positions(h, q, marker_set)
    return h, marker_set, positions


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ({"smoothing": float("nan")}, r"smoothing must be a number in \[0, 1e\+12\], got nan"),
        ({"damping": float("inf")}, r"damping must be"),
        ({"hold": -1.0}, r"hold must be"),
        ({"iterations": 0}, r"iterations must be at least 1"),
    ],
)
def test_bad_ik_settings_are_refused(setting, message):
    h, marker_set, positions = _standing_markers()
    markers = MarkerTrajectories(np.arange(4) * 0.01, list(marker_set), positions)
    with pytest.raises(HumanoidError, match=message):
        inverse_kinematics(h, markers, marker_set, **setting)


def test_an_infinite_marker_weight_is_refused():
    h, marker_set, positions = _standing_markers()
    name = next(iter(marker_set))
    marker_set[name] = Marker(marker_set[name].frame, marker_set[name].offset, float("inf"))
    markers = MarkerTrajectories(np.arange(4) * 0.01, list(marker_set), positions)
    with pytest.raises(HumanoidError, match=rf"marker '{name}': weight inf"):
        inverse_kinematics(h, markers, marker_set)


@pytest.mark.parametrize(
    ("time", "message"),
    [
        (np.zeros(4), r"time does not increase at frame 2"),  # IK divided by zero
        (np.array([0.0, 1e-12, 2e-12, 3e-12]), r"a rate above 100000 Hz"),
        (np.array([0.0, 0.01, np.inf, 0.03]), r"time of frame 3 is inf"),
    ],
)
def test_marker_trajectories_need_increasing_times(time, message):
    with pytest.raises(MotionFileError, match=message):
        MarkerTrajectories(time, ["a"], np.zeros((4, 1, 3)))


@pytest.mark.parametrize(
    ("time", "rate", "message"),
    [
        (np.arange(5) * 1e-12, None, r"a rate above 100000 Hz"),  # LinAlgError before
        (np.array([0.0, 0.01, 0.02, 1e9]), None, r"a gap of 1e\+09 s"),  # 74.5 GiB before
        (np.arange(5) * 0.01, 1e9, r"the rate must be in \(0, 100000\] Hz"),
        (np.arange(5) * 0.01, float("nan"), r"the rate must be in"),
    ],
)
def test_inverse_dynamics_refuses_a_bad_time_axis(time, rate, message):
    h = get_model("male", "quaternion")
    q = np.tile(h.standing_configuration(), (len(time), 1))
    with pytest.raises(HumanoidError, match=message):
        derivatives(h.model, time, q, rate=rate)


def test_a_study_of_a_million_runs_is_refused_before_listing_them(tmp_path):
    heights = [round(1.5 + 0.001 * i, 4) for i in range(400)]
    fractions = [round(0.001 * i, 4) for i in range(1, 201)]
    durations = [1.0 + 0.1 * i for i in range(20)]
    path = tmp_path / "big.toml"
    path.write_text(
        '[study]\nname = "big"\nrun = "scene"\nscene = "balance"\n[set]\n"body.sex" = "male"\n'
        '"body.bmi" = 22.0\n"push.frame" = "thorax"\n"push.direction" = "forward"\n'
        f'"push.start" = 0.5\n"push.duration" = 0.2\n[grid]\n"body.height" = {heights}\n'
        f'"push.fraction" = {fractions}\n"scene.duration" = {durations}\n'
    )
    with pytest.raises(hm.StudyError, match=r"grid: 400 x 200 x 20 = 1,600,000 runs, more than "
                       r"100,000"):  # fmt: skip
        load_study(path)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["info", ""], r"humanoid info: error: no model named"),
        (["view", "adult_male", "--fps", "1e9", "--html", "{tmp}/v.html"], r"--fps 1000000000.0"),
        (["view", "adult_male", "--speed", "nan", "--html", "{tmp}/v.html"], r"--speed nan"),
    ],
)
def test_bad_command_line_values_are_refused(tmp_path, argv, message):
    code, err = _cli([a.format(tmp=tmp_path) for a in argv])
    assert code == 2
    assert re.search(message, err), err


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["ik", str(TRIALS / "subject01_walk1.trc"), "-o"], "-o"),
        (["id", "x.mot", "-o"], "-o"),
        (["track", "x.mot", "-o"], "-o"),
        (["build", "--height", "1.7", "--mass", "70", "--sex", "male", "-o"], "-o"),
        (["walk", "-o"], "-o"),
        (["view", "adult_male", "--html"], "--html"),
        (["export", "adult_male", "--mjcf"], "--mjcf"),
    ],
)
def test_an_unwritable_output_is_refused_before_the_work(tmp_path, argv, option):
    blocker = tmp_path / "file"
    blocker.write_text("")
    code, err = _cli([*argv, str(blocker / "out.x")])  # a folder inside a file: cannot exist
    assert code == 2
    assert f"error: {option} {blocker / 'out.x'}: cannot create" in err


def test_a_misspelt_inertial_is_refused_naming_the_link(male_urdf):
    """urdfdom skips an unknown element: the pelvis lost its 8.4 kg (a 66.6 kg body)."""
    bad = male_urdf.replace("<inertial>", "<intertial>", 1).replace(
        "</inertial>", "</intertial>", 1
    )
    with pytest.raises(hm.ModelError, match=r"link 'pelvis': unknown element <intertial>: did "
                       r"you mean <inertial>\?"):  # fmt: skip
        hm.load(bad)


def test_an_unknown_link_element_is_warned_about(male_urdf):
    extended = male_urdf.replace("<inertial>", "<contact><lateral_friction value='1'/>"
                                 "</contact><inertial>", 1)  # fmt: skip
    with pytest.warns(hm.model.UnknownTagWarning, match=r"link 'pelvis': element <contact>"):
        h = hm.load(extended)
    assert sum(i.mass for i in h.model.inertias) == pytest.approx(75.0)


# -- the third fuzz run's findings (tests/test_fuzz_files.py, issue 38) ----------------------
@pytest.mark.parametrize(
    ("cut", "message"),
    [
        (100, r"100 bytes: not a C3D file"),
        (5000, r"the parameter section's \d+ blocks from block 2 run past the file's end"),
        (-1000, r"the header counts \d+ frames .*: a truncated file"),
    ],
)
def test_a_truncated_c3d_is_refused_before_ezc3d_reads_it(tmp_path, cut, message):
    """ezc3d crashed the interpreter (a segmentation fault) on a truncated file."""
    blob = (TRIALS / "walking5.c3d").read_bytes()
    path = tmp_path / "cut.c3d"
    path.write_bytes(blob[:cut])
    with pytest.raises(MotionFileError, match=message):
        read_c3d(path)


def test_a_c3d_parameter_of_too_many_dimensions_is_refused(tmp_path):
    from humanoid.motion.c3d_file import check_c3d

    blob = bytearray((TRIALS / "walking5.c3d").read_bytes())
    start = (blob[0] - 1) * 512
    at = blob.index(b"LABELS", start)  # POINT:LABELS: its dimension count after the offset
    blob[at + 6 + 3] = 172
    (tmp_path / "dims.c3d").write_bytes(bytes(blob))
    with pytest.raises(MotionFileError, match=r"parameter 'LABELS' has 172 dimensions"):
        check_c3d(tmp_path / "dims.c3d")


@pytest.mark.parametrize(
    ("field", "value"),
    [("translation", "[0.0, 1e300, 4.0]"), ("distortions", "[1e5, 0.0, 0.0, 0.0]")],
)
def test_a_calibration_out_of_this_world_is_refused(tmp_path, field, value):
    """A translation of 1e300 m overflowed the projection (found by the fuzz suite's seed 1)."""
    from humanoid.motion import cameras as cam

    path = cam.write_calibration(tmp_path / "c.toml", [cam.look_at("a", (4, 0, 1), (0, 0, 1))])
    text = "\n".join(f"{field} = {value}" if line.startswith(f"{field} =") else line
                     for line in path.read_text().splitlines())  # fmt: skip
    path.write_text(text)
    with pytest.raises(MotionFileError, match=rf"\[a\]: {field} has .*: not a calibration"):
        cam.read_calibration(path)


OVERLAP = r"\(100 characters\) runs into the next entry"


@pytest.mark.parametrize(("entry", "length", "words"),
                         [("parameter", 255, "is 255"), ("group", 255, "is 255"),
                          ("parameter", 100, OVERLAP)])  # fmt: skip
def test_a_c3d_description_ezc3d_cannot_read_is_refused(tmp_path, entry, length, words):
    """ezc3d reads a description's length as a signed byte: 255 is -1, and it crashed the
    interpreter; a description that runs into the next entry took it 12-28 s to refuse
    (found by the fuzz suite's seed 1, ``HUMANOID_FUZZ_SEED=1``)."""
    from humanoid.motion.c3d_file import check_c3d, parameter_table

    path = TRIALS / "walking5.c3d"
    blob = bytearray(path.read_bytes())
    if entry == "parameter":
        rate = parameter_table(path)[("POINT", "RATE")]
        blob[rate.data + rate.values * abs(rate.kind)] = length
    else:  # the POINT group's entry: its name's length, a negative id, the name
        start = (blob[0] - 1) * 512
        at = next(i for i in range(start, len(blob)) if blob[i : i + 5] == b"POINT"
                  and blob[i - 2] == 5 and blob[i - 1] >= 128)  # fmt: skip
        blob[at + 5 + 2] = length
    (tmp_path / "desc.c3d").write_bytes(bytes(blob))
    with pytest.raises(MotionFileError, match=rf"{entry} '\w+''s description {words}"):
        check_c3d(tmp_path / "desc.c3d")


def test_a_nan_coordinate_is_refused_naming_the_column(tmp_path):
    h, table = _coordinates(tmp_path, True)
    table.data[2, table.labels.index("knee_angle_r")] = np.nan
    with pytest.raises(MotionFileError, match=r"column 'knee_angle_r' is NaN at 1 samples"):
        configurations(h, table)


def test_a_nan_load_is_refused_naming_the_column(tmp_path):
    lines = list(GRF)
    lines[8] = lines[8].replace("103.2043876", "nan", 1)
    path = tmp_path / "grf.mot"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MotionFileError, match=r"column 'ground_force_vx' is NaN at 1 samples"):
        hm.motion.loads.read_loads(path, xml=TRIALS / "subject01_walk1_grf.xml")


def test_a_marker_on_a_frame_the_body_lacks_is_a_marker_set_error():
    from humanoid.errors import MarkerSetError

    h = get_model("male", "quaternion")
    with pytest.raises(MarkerSetError, match=r"puts markers on 'tail'"):
        hm.motion.markers.marker_positions(h, h.standing_configuration(), {"A": Marker("tail")})


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("kp.npz", b"PK", r"cannot read .*kp.npz"),
        ("s.npy", None, r"the points are not numbers"),
    ],
)
def test_bad_keypoint_files_are_refused(tmp_path, name, content, message):
    path = tmp_path / name
    if content is None:
        np.save(path, np.full((3, 17, 3), "a"))
    else:
        path.write_bytes(content)
    code, err = _cli(["ik", str(path), "--layout", "coco17", "-o", str(tmp_path / "o.mot")])
    assert code == 2
    assert re.search(message, err), err


def test_a_map_that_is_not_utf8_is_a_motion_file_error(tmp_path):
    path = tmp_path / "map.toml"
    path.write_bytes(MAP.encode() + b"\xff\n")
    with pytest.raises(MotionFileError, match=r"map.toml: not TOML"):
        read_map(path)


def test_a_study_body_of_1e300_m_is_refused_by_name():
    """BMI times height squared overflowed (an OverflowError; found by the fuzz suite's seed
    1): the height is refused as any height out of range is."""
    from humanoid.anthropometry import BodyParameterError
    from humanoid.study.build import body_parameters

    with pytest.raises(BodyParameterError, match="height"):
        body_parameters({"body.height": 1e300, "body.bmi": 25.0, "body.sex": "male"})
