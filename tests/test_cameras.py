"""Calibrated cameras and 2D keypoints (humanoid/motion/cameras.py), and inverse kinematics by
reprojection error: the projection and its Jacobian, Pose2Sim's calibration TOML, OpenPose's
JSON, triangulation, and a walk seen by four cameras fitted from its pixels."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pinocchio as pin
import pytest

from humanoid.errors import HumanoidError
from humanoid.motion.cameras import (
    Camera,
    CameraKeypoints,
    CameraWarning,
    camera_keypoints,
    look_at,
    match_cameras,
    read_calibration,
    read_openpose,
    triangulate,
    write_calibration,
    write_openpose,
)
from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.markers import (
    KEYPOINT_LAYOUTS,
    MarkerTrajectories,
    default_markers,
    marker_positions,
)
from humanoid.motion.storage import MotionFileError

DISTORTED = (-0.08, 0.02, 0.0007, -0.0004, 0.003)
EYES = [(4.0, 3.5, 1.6), (-2.5, 3.5, 1.6), (4.0, -3.5, 1.6), (-2.5, -3.5, 1.6)]
TARGET = (0.8, 0.0, 0.9)


def rig(distortions=DISTORTED) -> list[Camera]:
    """Four cameras around a walk along x, 5 m away, a lab's 1920x1080 at 1400 px focal."""
    return [look_at(f"cam{i + 1:02d}", e, TARGET, distortions=distortions)
            for i, e in enumerate(EYES)]  # fmt: skip


def test_projection_is_opencvs_and_its_jacobian_is_exact():
    """A point on the optical axis lands on the principal point; off-axis, the distortion
    moves it as OpenCV's formula does (written out here); the Jacobian equals central
    differences; normalised() undoes the distortion."""
    cam = rig()[0]
    on_axis = cam.centre + 3.0 * cam.rotation[2]
    np.testing.assert_allclose(cam.project(on_axis), cam.matrix[:2, 2], atol=1e-9)
    rng = np.random.default_rng(0)
    P = np.array(TARGET) + rng.normal(scale=0.6, size=(20, 3))
    x = P @ cam.rotation.T + cam.translation
    a, b = x[:, 0] / x[:, 2], x[:, 1] / x[:, 2]
    k1, k2, p1, p2, k3 = DISTORTED
    r2 = a * a + b * b
    rad = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
    ad = a * rad + 2 * p1 * a * b + p2 * (r2 + 2 * a * a)
    bd = b * rad + p1 * (r2 + 2 * b * b) + 2 * p2 * a * b
    K = cam.matrix
    opencv = np.c_[K[0, 0] * ad + K[0, 2], K[1, 1] * bd + K[1, 2]]
    np.testing.assert_allclose(cam.project(P), opencv, atol=1e-9)
    _, J = cam.project(P, jacobian=True)
    eps = 1e-6
    for d in range(3):
        step = np.zeros(3)
        step[d] = eps
        fd = (cam.project(P + step) - cam.project(P - step)) / (2 * eps)
        np.testing.assert_allclose(J[:, :, d], fd, rtol=1e-6, atol=1e-4)
    np.testing.assert_allclose(cam.normalised(cam.project(P)), np.c_[a, b], atol=1e-10)
    assert np.isnan(cam.project(cam.centre - cam.rotation[2])).all()  # behind: not seen


def test_look_at_sees_the_world_upright():
    """The world's z up is the image's up (v decreasing), the target at the image's centre."""
    cam = rig(distortions=(0, 0, 0, 0))[1]
    np.testing.assert_allclose(cam.project(np.array(TARGET)), [960, 540], atol=1e-9)
    up = cam.project(np.array(TARGET) + [0, 0, 0.5])
    assert up[1] < 540 - 100 and abs(up[0] - 960) < 1e-6


def test_a_calibration_round_trips_and_pose2sims_own_file_reads(tmp_path):
    cams = rig()
    back = read_calibration(write_calibration(tmp_path / "Calib.toml", cams))
    assert [c.name for c in back] == [c.name for c in cams]
    for c, d in zip(cams, back, strict=True):
        for f in ("matrix", "distortions", "rotation", "translation"):
            np.testing.assert_allclose(getattr(d, f), getattr(c, f), atol=1e-12)
    # as Pose2Sim writes it: four distortions, a Rodrigues rotation, a metadata table
    text = """[cam_01]
name = "cam_01"
size = [ 1088.0, 1920.0]
matrix = [ [ 1677.6, 0.0, 543.6], [ 0.0, 1677.6, 962.5], [ 0.0, 0.0, 1.0]]
distortions = [ -0.047, 0.12, 0.0004, -0.0003]
rotation = [ 1.6, 0.0, 0.0]
translation = [ 0.1, 0.9, 4.2]
fisheye = false

[metadata]
adjusted = false
error = 0.0
"""
    (tmp_path / "p2s.toml").write_text(text)
    (cam,) = read_calibration(tmp_path / "p2s.toml")
    assert cam.size == (1088.0, 1920.0) and cam.distortions[4] == 0.0
    np.testing.assert_allclose(cam.rotation, pin.exp3(np.array([1.6, 0.0, 0.0])))


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda t: t.replace("distortions = [ -0.047, 0.12, 0.0004, -0.0003]\n", ""),
         ["[cam_01]", "distortions"]),
        (lambda t: t.replace("fisheye = false", "fisheye = true"), ["[cam_01]", "fisheye"]),
        (lambda t: t.replace("-0.0003]", "-0.0003, 0.1, 0.2]"), ["[cam_01]", "distortions"]),
        (lambda t: t.replace("1677.6, 0.0, 543.6", "-1.0, 0.0, 543.6"), ["[cam_01]", "focal"]),
        (lambda t: "[metadata]\nerror = 0.0\n", ["no camera"]),
    ],
)  # fmt: skip
def test_a_bad_calibration_names_its_camera_and_field(tmp_path, edit, words):
    text = """[cam_01]
name = "cam_01"
size = [ 1088.0, 1920.0]
matrix = [ [ 1677.6, 0.0, 543.6], [ 0.0, 1677.6, 962.5], [ 0.0, 0.0, 1.0]]
distortions = [ -0.047, 0.12, 0.0004, -0.0003]
rotation = [ 1.6, 0.0, 0.0]
translation = [ 0.1, 0.9, 4.2]
fisheye = false
"""
    path = tmp_path / "bad.toml"
    path.write_text(edit(text))
    with pytest.raises(MotionFileError) as err:
        read_calibration(path)
    assert str(path) in str(err.value)
    for w in words:
        assert w in str(err.value), err.value


@pytest.fixture(scope="module")
def seen_walk(walk_1khz):
    """The walk's BODY_25 points at 50 Hz, projected by the four cameras."""
    h, tr = walk_1khz
    t, q = tr.t[::20], tr.q[::20]
    names = KEYPOINT_LAYOUTS["body25"]
    ms = default_markers(h)
    pts = np.full((len(t), len(names), 3), np.nan)
    idx = [i for i, n in enumerate(names) if n]
    pts[:, idx] = marker_positions(h, q, ms, [names[i] for i in idx])
    cams = rig()
    uv = np.array([c.project(pts) for c in cams])
    return h, t, q, ms, cams, uv


def test_openpose_json_round_trips_and_keeps_the_most_confident_person(tmp_path, seen_walk):
    h, t, q, ms, cams, uv = seen_walk
    conf = np.where(np.isfinite(uv[..., 0]), 0.8, 0.0)
    names = [c.name for c in cams]
    folders = write_openpose(tmp_path / "pose", uv, conf, names)
    # a bystander in one frame of cam02, less confident: the person is kept
    f = sorted(folders[1].glob("*.json"))[3]
    doc = json.loads(f.read_text())
    doc["people"].insert(0, {"pose_keypoints_2d": [1.0, 2.0, 0.1] * 25})
    f.write_text(json.dumps(doc))
    with pytest.warns(CameraWarning, match="cam02_json \\(1 frames\\)"):
        kp = read_openpose(tmp_path / "pose", "body25", rate=50.0)
    assert kp.cameras == [f"{n}_json" for n in names]
    assert kp.names == [n for n in KEYPOINT_LAYOUTS["body25"] if n]
    keep = [i for i, n in enumerate(KEYPOINT_LAYOUTS["body25"]) if n]
    np.testing.assert_allclose(kp.uv, uv[:, :, keep], atol=1e-9)
    np.testing.assert_allclose(kp.time, t - t[0], atol=1e-12)
    # Pose2Sim's names sort by their last number: frame 10 after frame 9
    assert sorted(p.name for p in folders[0].glob("*.json"))[:2] == [
        "cam01_000000_keypoints.json", "cam01_000001_keypoints.json"]  # fmt: skip


def test_bad_keypoints_are_named(tmp_path, seen_walk):
    h, t, q, ms, cams, uv = seen_walk
    conf = np.where(np.isfinite(uv[..., 0]), 0.8, 0.0)
    with pytest.raises(HumanoidError, match="confidence 0"):
        camera_keypoints(t, uv, np.zeros_like(conf), "body25", ["a", "b", "c", "d"])
    folders = write_openpose(tmp_path / "pose", uv, conf, ["a", "b", "c", "d"])
    next(iter(folders[2].glob("*.json"))).unlink()
    with pytest.raises(MotionFileError, match="different frame counts.*c_json 70"):
        read_openpose(tmp_path / "pose", "body25", rate=50.0)
    with pytest.raises(MotionFileError, match="75"):  # COCO's 17 points are not BODY_25's 25
        read_openpose(tmp_path / "pose", "coco17", rate=50.0, folders=[folders[0]])
    bad = tmp_path / "notjson_json"
    bad.mkdir()
    (bad / "x_0.json").write_text("{not json")
    with pytest.raises(MotionFileError, match="x_0.json"):
        read_openpose(tmp_path, "body25", rate=50.0, folders=[bad])


def test_a_calibration_that_is_not_the_recordings_is_said(seen_walk):
    h, t, q, ms, cams, uv = seen_walk
    kp = camera_keypoints(t, uv, np.where(np.isfinite(uv[..., 0]), 0.9, 0.0), "body25",
                          [c.name for c in cams])  # fmt: skip
    with pytest.raises(HumanoidError, match="has 3 cameras.*4"):
        match_cameras(kp, cams[:3])
    small = [look_at(c.name, e, TARGET, size=(640, 480)) for c, e in zip(cams, EYES, strict=True)]
    with pytest.warns(CameraWarning, match="fall outside"):
        match_cameras(kp, small)
    swapped = [cams[1], cams[0], cams[3], cams[2]]  # the right images, the wrong order
    with pytest.warns(CameraWarning, match="reprojection error"):
        triangulate(kp, swapped)


def test_triangulation_gives_the_points_back(seen_walk):
    """Noise-free pixels through distorted lenses: the points to 1e-6 m; a point one camera
    alone sees is not triangulated."""
    h, t, q, ms, cams, uv = seen_walk
    conf = np.where(np.isfinite(uv[..., 0]), 0.9, 0.0)
    conf[1:, 0, 2] = 0.0  # the third point of the first frame seen by cam01 alone
    kp = camera_keypoints(t, uv, conf, "body25", [c.name for c in cams])
    tri = triangulate(kp, cams)
    truth = marker_positions(h, q, ms, kp.names)
    assert np.isnan(tri.positions[0, 1]).all()  # (point 2 of the layout is the 2nd kept)
    ok = np.isfinite(tri.positions[..., 0])
    assert ok.sum() == ok.size - 1
    np.testing.assert_allclose(tri.positions[ok], truth[ok], atol=1e-6)


def test_inverse_kinematics_by_reprojection_fits_the_walk(seen_walk):
    """Four cameras, 3 px of noise, confidence 0.9 (one camera's left knee at 0.05 and
    30 px off: weighed by its confidence it hardly moves the fit): the joints within 4 deg
    RMS of the walk's, the reprojection error near the noise; without the noise, the fit to
    the same points in 3D within 0.5 deg."""
    h, t, q, ms, cams, uv = seen_walk
    model = h.model

    def rms(fit, q=q):
        d = np.array([pin.difference(model, a, b)[6:] for a, b in zip(fit.q, q, strict=True)])
        return float(np.degrees(np.sqrt(np.mean(d**2))))

    conf = np.where(np.isfinite(uv[..., 0]), 0.9, 0.0)
    names = [c.name for c in cams]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (held hands and neck: no keypoint sees them)
        full = np.where(conf > 0, 1.0, 0.0)  # (as the 3D markers' weights)
        clean = inverse_kinematics(h, camera_keypoints(t, uv, full, "body25", names), ms,
                                   cameras=cams)  # fmt: skip
        rng = np.random.default_rng(1)
        noisy = uv + rng.normal(scale=3.0, size=uv.shape)
        knee = KEYPOINT_LAYOUTS["body25"].index("left_knee")
        noisy[2, :, knee] += 30.0
        conf[2, :, knee] = 0.05
        fit = inverse_kinematics(h, camera_keypoints(t, noisy, conf, "body25", names), ms,
                                 cameras=cams)  # fmt: skip
        names3d = [n for n in KEYPOINT_LAYOUTS["body25"] if n]
        in3d = inverse_kinematics(
            h, MarkerTrajectories(t, names3d, marker_positions(h, q, ms, names3d)), ms
        )
    # (0.29 deg: the pull towards the frame before acts on a data term of another shape, rays
    # seen from four sides instead of points)
    assert rms(clean, in3d.q) < 0.5, rms(clean, in3d.q)
    assert np.nanmax(clean.pixels) < 1.0  # (0.7: the same pulls)
    assert rms(fit) < 4.0, rms(fit)
    assert 2.0 < np.nanmedian(fit.pixels) < 5.0, np.nanmedian(fit.pixels)
    # the residuals are distances from the rays [m]: a pixel is about 3.6 mm at 5 m
    assert 0.004 < np.nanmedian(fit.residuals) < 0.02
    with pytest.raises(HumanoidError, match="need their cameras"):
        inverse_kinematics(h, camera_keypoints(t, uv, conf, "body25", names), ms)


def test_keypoints_check_their_shapes():
    with pytest.raises(HumanoidError, match="cameras, frames"):
        CameraKeypoints(np.arange(3.0), ["a"], ["c1", "c2"], np.zeros((2, 3, 2, 2)),
                        np.ones((2, 3, 2)))  # fmt: skip
    with pytest.raises(HumanoidError, match="increasing"):
        CameraKeypoints(np.zeros(3), ["a"], ["c1"], np.zeros((1, 3, 1, 2)), np.ones((1, 3, 1)))


def test_cli_ik_fits_camera_folders_to_their_calibration(tmp_path, seen_walk, capsys):
    """``humanoid ik pose/ --calibration Calib.toml --layout body25 --rate 50``: Pose2Sim's
    layout in, the coordinates out, the reprojection error printed; ``humanoid track`` takes
    the same folders; a calibration with one camera fewer is refused naming both."""
    from humanoid.cli import main
    from humanoid.data import BODIES

    h, t, q, ms, cams, uv = seen_walk
    rng = np.random.default_rng(2)
    noisy = uv[:, :20] + rng.normal(scale=2.0, size=uv[:, :20].shape)
    conf = np.where(np.isfinite(noisy[..., 0]), 0.9, 0.0)
    write_openpose(tmp_path / "pose", noisy, conf, [c.name for c in cams])
    calib = write_calibration(tmp_path / "Calib.toml", cams)
    out = tmp_path / "ik.mot"
    args = ["ik", str(tmp_path / "pose"), "--calibration", str(calib), "--layout", "body25",
            "--rate", "50", "--model", str(BODIES / "adult_male.urdf"), "-o", str(out)]  # fmt: skip
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "reprojected  4 cameras" in text and out.exists()
    px = float(text.split("reprojected  4 cameras, RMS per frame: mean ")[1].split(" px")[0])
    assert 1.0 < px < 4.0, text
    # the markerless pipeline to the end: the same folders tracked in forward simulation
    run = tmp_path / "tracked.npz"
    assert main(["track", *args[1:-2], "-o", str(run)]) == 0
    text = capsys.readouterr().out
    assert "status       completed" in text and run.exists(), text
    write_calibration(calib, cams[:3])
    assert main(args) != 0
    err = capsys.readouterr().err
    assert "has 3 cameras" in err and "cam04_json" in err, err
