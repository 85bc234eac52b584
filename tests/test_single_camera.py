"""Markerless motion from ONE calibrated camera (humanoid/motion/monocular.py and the
single-view defaults of inverse kinematics): the walk's BODY_25 points seen from the side, 5 m
away, at 30 Hz with 3 px of noise, fitted and measured against the walk itself; a calibration
seeing too little is refused; the CLI takes a calibration with one camera."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from humanoid.errors import HumanoidError
from humanoid.motion.cameras import camera_keypoints, look_at
from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.markers import KEYPOINT_LAYOUTS, default_markers, marker_positions
from humanoid.motion.monocular import SingleViewWarning

RATE = 30.0
LENS = (-0.05, 0.01, 0.0005, -0.0003, 0.0)


@pytest.fixture(scope="module")
def side_view(walk_1khz):
    """The walk every 33rd millisecond, its BODY_25 points in one camera 5 m to its right
    (1.6 m high, 1920x1080, 1400 px focal, a distorted lens), clean pixels."""
    h, tr = walk_1khz
    t, q = tr.t[::33], tr.q[::33]
    middle = 0.5 * (q[0, :3] + q[-1, :3])
    cam = look_at("side", middle + (0.0, -5.0, 0.0) + (0.0, 0.0, 1.6 - middle[2]),
                  (middle[0], middle[1], 0.9), distortions=LENS)  # fmt: skip
    names = KEYPOINT_LAYOUTS["body25"]
    keep = [i for i, n in enumerate(names) if n]
    pts = np.full((len(t), len(names), 3), np.nan)
    pts[:, keep] = marker_positions(h, q, default_markers(h), [names[i] for i in keep])
    return h, t, q, cam, cam.project(pts)[None]


def fit(h, t, uv, cam, seed=0, noise=3.0, **kw):
    rng = np.random.default_rng(seed)
    noisy = uv + rng.normal(scale=noise, size=uv.shape)
    kp = camera_keypoints(t, noisy, np.where(np.isfinite(noisy[..., 0]), 0.9, 0.0), "body25",
                          [cam.name])  # fmt: skip
    return inverse_kinematics(h, kp, default_markers(h), cameras=[cam], **kw)


def errors(h, q_fit, q, cam):
    """The joints' RMS error [deg]; the root's RMS error along the camera's ray and across
    it [m]."""
    d = np.array([pin.difference(h.model, a, b)[6:] for a, b in zip(q_fit, q, strict=True)])
    ray = q[:, :3] - cam.centre
    u = ray / np.linalg.norm(ray, axis=1, keepdims=True)
    e = q_fit[:, :3] - q[:, :3]
    along = np.sum(e * u, axis=1)
    across = np.linalg.norm(e - along[:, None] * u, axis=1)
    return (float(np.degrees(np.sqrt(np.mean(d**2)))), float(np.sqrt(np.mean(along**2))),
            float(np.sqrt(np.mean(across**2))))  # fmt: skip


def test_one_side_camera_fits_the_walk(side_view):
    """3 px of noise, one view: the joints within 5 deg RMS of the walk's (3.4-4.1 measured on
    seeds 0-4 by scripts/single_camera.py; four cameras: 2.6-3.7), the root within 10 cm
    along the ray (37-74 mm) and 1.5 cm across it (6-7 mm); the depth report flags few
    frames; the feet on the floor."""
    h, t, q, cam, uv = side_view
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # (the unseen hands and neck)
        warnings.simplefilter("error", SingleViewWarning)
        r = fit(h, t, uv, cam)
    joints, along, across = errors(h, r.q, q, cam)
    assert joints < 5.0 and along < 0.10 and across < 0.015, (joints, along, across)
    assert r.depth is not None and r.depth.camera == "side"
    assert r.depth.weak.sum() <= 3, r.depth.summary()
    assert 2.0 < r.depth.pixels < 4.5
    assert "weakly observed" in r.depth.summary()
    # the feet on the floor: the lowest sole point within 5 mm of z = 0 in every frame
    from humanoid.motion.coordinates import lowest_sole_point

    low = np.array([lowest_sole_point(h, x[None]) for x in r.q])
    assert np.abs(low).max() < 0.03 and np.sqrt(np.mean(low**2)) < 0.005, low


def test_one_camera_seeing_too_little_is_refused(side_view):
    h, t, q, cam, uv = side_view
    few = np.full_like(uv, np.nan)
    few[:, :, 1:3] = uv[:, :, 1:3]  # two points only
    with pytest.raises(HumanoidError, match="fewer than 3"):
        fit(h, t[:3], few[:, :3], cam, noise=0.0)


def test_cli_takes_a_calibration_with_one_camera(tmp_path, side_view, capsys):
    """``humanoid ik pose/ --calibration Calib.toml`` with one camera: the reprojection error
    and a line saying the depth is weakly observed are printed."""
    from humanoid.cli import main
    from humanoid.data import BODIES
    from humanoid.motion.cameras import write_calibration, write_openpose

    h, t, q, cam, uv = side_view
    rng = np.random.default_rng(3)
    noisy = uv[:, :12] + rng.normal(scale=2.0, size=uv[:, :12].shape)
    write_openpose(tmp_path / "pose", noisy, np.where(np.isfinite(noisy[..., 0]), 0.9, 0.0),
                   [cam.name])  # fmt: skip
    calib = write_calibration(tmp_path / "Calib.toml", [cam])
    out = tmp_path / "ik.mot"
    assert main(["ik", str(tmp_path / "pose"), "--calibration", str(calib), "--layout",
                 "body25", "--rate", "30", "--model", str(BODIES / "adult_male.urdf"), "-o",
                 str(out)]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert "reprojected  1 camera, RMS per frame" in text, text
    assert "depth        one camera (side" in text and "weakly observed" in text, text
    assert out.exists()
