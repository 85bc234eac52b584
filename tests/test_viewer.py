"""The viewer without a browser: the commands sent to meshcat, the HTML file, the server."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pinocchio as pin
import pytest
from conftest import BODIES, SCENES, get_model, landing_run

import humanoid as hm
from humanoid.scene import Scene

viewer = pytest.importorskip("humanoid.viewer")
meshcat = pytest.importorskip("meshcat")


def _recorded(h, overlays=None):
    rec = viewer.CommandRecorder()
    vis = meshcat.Visualizer(window=rec)
    view = viewer.SceneView(vis, h, overlays or viewer.Overlays())
    return rec, view


def _paths(rec, kind):
    return [c["path"] for c in rec.commands if c["type"] == kind]


@pytest.fixture(scope="module")
def landing():
    return landing_run(0.5)


def test_scene_has_every_visual_geometry_and_the_overlays():
    h = get_model("male", "quaternion")
    rec, _ = _recorded(h)
    objects = _paths(rec, "set_object")
    for g in h.visual_model.geometryObjects:
        assert f"/meshcat/humanoid/body/{g.name}/shape" in objects
    for overlay in ("com", "com_ground/disc", "ground", "forces/left/length/shaft",
                    "forces/right/length/head", "footprints/left/box"):  # fmt: skip
        assert f"/meshcat/humanoid/{overlay}" in objects, overlay


def test_overlays_can_be_switched_off():
    h = get_model("male", "quaternion")
    rec, _ = _recorded(h, viewer.Overlays(forces=False, com=False, footprints=False, ground=False))
    objects = _paths(rec, "set_object")
    assert all("/body/" in p for p in objects), objects
    grid = [c for c in rec.commands if c["path"] == "/Grid"]
    assert grid and grid[-1]["value"] is False


def test_meshes_of_erd_human_are_loaded_with_their_scale():
    h = get_model("human", "quaternion")
    rec, _ = _recorded(h)
    meshes = [c for c in rec.commands if c["type"] == "set_object" and "/body/" in c["path"]]
    assert len(meshes) == h.visual_model.ngeoms == 23
    assert all(c["object"]["geometries"][0]["type"] == "_meshfile" for c in meshes)
    assert {c["object"]["geometries"][0]["format"] for c in meshes} == {"stl"}
    fixes = {c["path"]: c["matrix"] for c in rec.commands if c["type"] == "set_transform"}
    g = h.visual_model.geometryObjects[0]
    scale = np.array(fixes[f"/meshcat/humanoid/body/{g.name}/shape"]).reshape(4, 4).T
    assert np.allclose(np.diag(scale)[:3], g.meshScale)


def test_frame_places_bodies_com_and_force_arrows(landing):
    h = get_model("male", "quaternion")
    _, view = _recorded(h)
    i = len(landing.t) - 1
    q = landing.q[i]
    forces = {k: landing.forces[k][i] for k in ("left", "right")}
    out = {(path, kind): value for path, kind, value in view.frame(q, forces)}
    data = h.model.createData()
    gdata = pin.GeometryData(h.visual_model)
    pin.forwardKinematics(h.model, data, q)
    pin.updateGeometryPlacements(h.model, data, h.visual_model, gdata)
    for k, g in enumerate(h.visual_model.geometryObjects):
        assert np.allclose(out[(("body", g.name), "transform")], gdata.oMg[k].homogeneous)
    com = hm.centre_of_mass(h, q)
    assert np.allclose(out[(("com",), "transform")][:3, 3], com)
    assert np.allclose(out[(("com_ground",), "transform")][:3, 3], [com[0], com[1], 0.002])
    f = forces["left"][:3]
    assert out[(("forces", "left"), "visible")] is True
    length = out[(("forces", "left", "length"), "scale")][2]
    assert length == pytest.approx(0.5 * np.linalg.norm(f) / (h.mass * 9.81))
    R = out[(("forces", "left"), "transform")][:3, :3]
    assert np.allclose(R[:, 2], f / np.linalg.norm(f))
    # centre of pressure: the arrow starts on the ground, under the sole
    assert out[(("forces", "left"), "transform")][2, 3] == pytest.approx(0.0, abs=1e-3)
    # before touchdown the feet carry nothing: arrows and footprints hidden
    out0 = {
        (p, k): v
        for p, k, v in view.frame(
            landing.q[0], {s: landing.forces[s][0] for s in ("left", "right")}
        )
    }
    assert out0[(("forces", "left"), "visible")] is False
    assert out0[(("footprints", "left"), "visible")] is False


def test_animation_frames_follow_the_trajectory_at_the_chosen_speed(landing):
    h = get_model("male", "quaternion")
    for speed, fps in ((1.0, 30.0), (0.5, 20.0)):
        rec, view = _recorded(h)
        n = view.animate(landing, speed=speed, fps=fps)
        assert n == int(np.floor(0.5 / speed * fps)) + 1
        anim = [c for c in rec.commands if c["type"] == "set_animation"]
        assert len(anim) == 1
        clips = {a["path"]: a["clip"] for a in anim[0]["animations"]}
        foot = "/meshcat/humanoid/body/left_foot_0"
        track = next(t for t in clips[foot]["tracks"] if t["name"] == ".position")
        assert len(track["keys"]) == n and clips[foot]["fps"] == fps
        z = [k["value"][2] for k in track["keys"]]
        assert z[0] > z[-1] + 0.04  # the foot falls 5 cm, then stays on the ground
    with pytest.raises(hm.HumanoidError, match="give a playback speed in"):
        view.animate(landing, speed=0.0)


def test_animation_keys_are_the_trajectory_interpolated_at_their_times(landing):
    """Key k of an animation at ``speed`` and ``fps`` shows the run at t0 + k speed / fps,
    interpolated between its records on the Lie group: at half speed and 30 fps, key 1 is
    at 16.7 ms, two thirds of the way from the 10 ms record to the 20 ms one (planted, the
    speed ignored and the interpolation turned round each passed the test above)."""
    h = get_model("male", "quaternion")
    rec, view = _recorded(h)
    speed, fps = 0.5, 30.0
    view.animate(landing, speed=speed, fps=fps)
    anim = next(c for c in rec.commands if c["type"] == "set_animation")
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    track = next(t for t in clips["/meshcat/humanoid/body/left_foot_0"]["tracks"]
                 if t["name"] == ".position")  # fmt: skip
    g = h.visual_model.getGeometryId("left_foot_0")
    data, gdata = h.model.createData(), pin.GeometryData(h.visual_model)
    t = np.asarray(landing.t)
    for k in (1, 2, 4, 7, 20):
        time_k = t[0] + k * speed / fps
        i = int(np.searchsorted(t, time_k, side="right")) - 1
        s = (time_k - t[i]) / (t[i + 1] - t[i])
        q = pin.interpolate(h.model, landing.q[i], landing.q[i + 1], s)
        pin.forwardKinematics(h.model, data, q)
        pin.updateGeometryPlacements(h.model, data, h.visual_model, gdata)
        np.testing.assert_allclose(track["keys"][k]["value"], gdata.oMg[g].translation,
                                   rtol=0, atol=1e-6, err_msg=str(k))  # fmt: skip
    moved = np.ptp([k["value"][2] for k in track["keys"][:8]])
    assert moved > 1e-3  # the foot falls over these keys: they tell the times apart


def test_html_export_is_self_contained(tmp_path, landing):
    h = get_model("male", "quaternion")
    path = viewer.export_html(h, tmp_path / "run.html", traj=landing, title="landing")
    text = path.read_text()
    assert text.startswith("<!DOCTYPE html>") and "humanoidCommands" in text
    assert "<script src=" not in text and "<link" not in text  # nothing loaded from elsewhere
    assert 0.8e6 < path.stat().st_size < 20e6
    pose = viewer.export_html(h, tmp_path / "pose.html")
    assert pose.stat().st_size < path.stat().st_size


def test_trajectory_knows_its_body(landing):
    h = viewer.humanoid_for(landing)
    assert h.nq == landing.q.shape[1]
    params_scene = Scene(body=hm.BodyParameters(1.6, 60.0, "female"), duration=0.01)
    traj = hm.simulate(params_scene, quiet=True)
    assert viewer.humanoid_for(traj).mass == pytest.approx(60.0)


def _listening(pid: int) -> list[str]:
    out = subprocess.run(["ss", "-ltnpH"], capture_output=True, text=True, check=True).stdout
    return [line.split()[3] for line in out.splitlines() if f"pid={pid}," in line]


def test_live_server_listens_on_loopback_only_and_stops():
    with viewer.LiveViewer() as live:
        pid = live.proc.pid
        addresses = _listening(pid)
        assert len(addresses) == 2, addresses  # the web port and the ZMQ port
        assert all(a.startswith("127.0.0.1:") for a in addresses), addresses
        assert live.url.startswith("http://127.0.0.1:")
    assert live.proc.poll() is not None
    assert not _listening(pid)


def test_live_server_dies_with_a_killed_parent(tmp_path):
    code = (
        "import sys, time\n"
        "from humanoid.viewer import LiveViewer\n"
        "v = LiveViewer()\n"
        "print(v.proc.pid, flush=True)\n"
        "time.sleep(60)\n"
    )
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        server = int(parent.stdout.readline())  # LiveViewer prints nothing itself
    finally:
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and os.path.exists(f"/proc/{server}"):
        status = open(f"/proc/{server}/status").read() if os.path.exists(f"/proc/{server}") else ""
        if "zombie" in status:
            break
        time.sleep(0.1)
    alive = (
        os.path.exists(f"/proc/{server}") and "zombie" not in open(f"/proc/{server}/status").read()
    )
    assert not alive, "the meshcat server outlived its killed parent"


def test_talos_is_drawn_from_its_meshes():
    h = get_model("talos", "quaternion")
    rec, _ = _recorded(h)
    meshes = [c for c in rec.commands if c["type"] == "set_object" and "/body/" in c["path"]]
    assert len(meshes) == h.visual_model.ngeoms > 20
    kinds = {c["object"]["geometries"][0]["type"] for c in meshes}
    assert "_meshfile" in kinds and kinds <= {"_meshfile", "CylinderGeometry", "BoxGeometry"}


def test_a_push_is_an_arrow_on_the_pushed_point_while_it_acts():
    """push.toml's 80 N at the thorax: the arrow's tip is on the thorax frame, it points along
    the force, its length is the force scale times PUSH_GAIN, and it is hidden before and after
    the push; the animation keys its visibility on and off at the push's window."""
    from humanoid.simulation import simulate

    scene = Scene.load(SCENES / "push.toml").replace(duration=1.0)
    traj = simulate(scene, quiet=True)
    h = get_model("male", "quaternion")
    rec, view = _recorded(h)
    view.set_pushes(viewer._pushes(h.model, traj.metadata))
    assert "/meshcat/humanoid/pushes/0/length/shaft" in _paths(rec, "set_object")
    i = int(np.searchsorted(traj.t, 0.6))
    out = {(p, k): v for p, k, v in view.frame(traj.q[i], {}, traj.t[i])}
    assert out[(("pushes", "0"), "visible")] is True
    T = out[(("pushes", "0"), "transform")]
    length = out[(("pushes", "0", "length"), "scale")][2]
    assert length == pytest.approx(viewer.PUSH_GAIN * 0.5 * 80.0 / (h.mass * 9.81))
    assert np.allclose(T[:3, 2], [1.0, 0.0, 0.0])  # along the force
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, traj.q[i])
    tip = T[:3, 3] + length * T[:3, 2]
    assert np.allclose(tip, data.oMf[h.model.getFrameId("thorax")].translation)
    for t in (0.4, 0.85):
        k = int(np.searchsorted(traj.t, t))
        shown = {(p, kk): v for p, kk, v in view.frame(traj.q[k], {}, traj.t[k])}
        assert shown[(("pushes", "0"), "visible")] is False
    rec, view = _recorded(h)
    view.animate(traj, fps=10.0)
    anim = next(c for c in rec.commands if c["type"] == "set_animation")
    clip = next(a["clip"] for a in anim["animations"] if a["path"].endswith("/pushes/0"))
    keys = next(t for t in clip["tracks"] if t["name"] == ".visible")["keys"]
    on = [k["time"] / 10.0 for k in keys if k["value"]]
    assert on and min(on) == pytest.approx(0.5) and max(on) == pytest.approx(0.7)


def test_the_ground_force_is_an_arrow_at_its_centre_of_pressure():
    """Lying on the floor at the end of the drop: one arrow, the floor's total force, at the
    centre of pressure of the contact points (inside their span), carrying the weight."""
    from humanoid.simulation import Simulation

    scene = Scene.load(SCENES / "drop.toml").replace(duration=0.05, record_rate=1000.0)
    scene = scene.replace(initial=type(scene.initial)(lift=0.0))  # standing on the floor
    sim = Simulation(scene)
    traj = sim.run(quiet=True)
    h = get_model("male", "quaternion")
    _, view = _recorded(h)
    w = traj.forces["ground"][-1]
    out = {(p, k): v for p, k, v in view.frame(traj.q[-1], {"ground": w})}
    assert out[(("forces", "ground"), "visible")] is True
    cop = out[(("forces", "ground"), "transform")][:3, 3]
    points = sim.ground_step.points
    assert cop[2] == 0.0
    assert np.all(cop[:2] >= points[:, :2].min(axis=0)) and np.all(
        cop[:2] <= points[:, :2].max(axis=0)
    )
    # the CoP of the impulses themselves
    lam = sim.ground_step.impulses
    assert np.allclose(
        cop[:2], (points[:, :2] * lam[:, 2:3]).sum(axis=0) / lam[:, 2].sum(), atol=1e-3
    )
    length = out[(("forces", "ground", "length"), "scale")][2]
    assert length == pytest.approx(0.5 * np.linalg.norm(w[:3]) / (h.mass * 9.81))


# -- the recording, the camera, the legend --------------------------------------------------


def _carried(h, distance: float, duration: float, n: int, heading: float = 0.0):
    """The standing body carried ``distance`` [m] in ``duration`` [s] along the heading [rad]
    (turned to face it), recorded ``n`` times, no forces: a walk's camera problem without a
    walk."""
    from humanoid.simulation import Trajectory

    t = np.linspace(0.0, duration, n)
    q = np.tile(h.standing_configuration(), (n, 1))
    q[:, 0] += distance * t / duration * np.cos(heading)
    q[:, 1] += distance * t / duration * np.sin(heading)
    q[:, 3:7] = pin.Quaternion(pin.utils.rotate("z", heading)).coeffs()
    q[:, 2] -= 0.05 * np.sin(2 * np.pi * t)  # the pelvis bobs
    zeros = np.zeros((n, h.nv))
    return Trajectory(t, q, zeros, zeros.copy(), {}, np.zeros(n), np.zeros(n), {})


def _recording(h, traj, missing=("R.Heel", 3)):
    """Measured markers: the default set's on the body, each moved by its own offset (a
    residual of 1-4 cm, every marker's different), one missing in one frame."""
    from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions

    marker_set = default_markers(h)
    names = list(marker_set)
    model = marker_positions(h, traj.q, marker_set, names)
    rng = np.random.default_rng(3)
    offsets = rng.uniform(-0.02, 0.02, (len(names), 3))
    measured = model + offsets
    name, frame = missing
    measured[frame, names.index(name)] = np.nan
    return MarkerTrajectories(traj.t, names, measured, "trial.trc"), marker_set, model


def _last(rec, path, kind, prop=None):
    for c in reversed(rec.commands):
        if c["path"] == path and c["type"] == kind and (prop is None or c["property"] == prop):
            return c
    return None


def _endpoints(matrix, scale):
    T = np.array(matrix).reshape(4, 4).T
    return T[:3, 3], T[:3, 3] + scale[2] * T[:3, 2]


def test_the_recording_is_drawn_beside_the_body_with_its_residuals():
    """Every measured marker where the file has it, its model marker where the set puts it on
    the body, and a residual line from the one to the other; R.Heel, missing in frame 3, hidden
    there (marker and line: not drawn at the origin); left and right not swapped."""
    h = get_model("male", "quaternion")
    traj = _carried(h, 0.5, 1.0, 11)
    measured, marker_set, model = _recording(h, traj)
    rec, view = _recorded(h)
    with pytest.warns(viewer.HiddenMarkerWarning, match=r"R\.Heel \(1 of 11 frames\)"):
        drawn = view.set_markers(measured, marker_set)
    assert drawn == measured.names
    objects = _paths(rec, "set_object")
    for n in ("R.ASIS", "L.ASIS", "right_knee", "left_knee"):
        assert f"/meshcat/humanoid/markers/measured/{n}" in objects
        assert f"/meshcat/humanoid/markers/model/{n}" in objects
        assert f"/meshcat/humanoid/markers/residual/{n}/length/line" in objects
    base = "/meshcat/humanoid/markers"
    for i in (5, 3):
        view.show(traj.q[i], {}, traj.t[i])
        for k, n in enumerate(measured.names):
            seen = not (n == "R.Heel" and i == 3)
            model_p = _last(rec, f"{base}/model/{n}", "set_property", "position")["value"]
            assert np.allclose(model_p, model[i, k], atol=1e-9), n
            shown = _last(rec, f"{base}/measured/{n}", "set_property", "visible")["value"]
            line = _last(rec, f"{base}/residual/{n}", "set_property", "visible")["value"]
            assert shown is seen and line is seen, n
            if not seen:
                continue
            p = _last(rec, f"{base}/measured/{n}", "set_property", "position")["value"]
            assert np.allclose(p, measured.positions[i, k], atol=1e-9), n
            T = _last(rec, f"{base}/residual/{n}", "set_transform")["matrix"]
            scale = _last(rec, f"{base}/residual/{n}/length", "set_property", "scale")["value"]
            tail, head = _endpoints(T, scale)
            assert np.allclose(tail, model[i, k], atol=1e-9), n
            assert np.allclose(head, measured.positions[i, k], atol=1e-9), n
    # the animation: keyed at the records (10 frames per second), the same places
    rec, view = _recorded(h)
    with pytest.warns(viewer.HiddenMarkerWarning):
        view.set_markers(measured, marker_set)
    view.animate(traj, fps=10.0)
    anim = next(c for c in rec.commands if c["type"] == "set_animation")
    clips = {a["path"]: a["clip"] for a in anim["animations"]}

    def keys(path, name):
        return [
            k["value"] for k in next(t for t in clips[path]["tracks"] if t["name"] == name)["keys"]
        ]  # noqa: E501

    k_heel, k_toe = measured.names.index("R.Heel"), measured.names.index("L.Toe.Tip")
    assert np.allclose(
        keys(f"{base}/measured/L.Toe.Tip", ".position"), measured.positions[:, k_toe]
    )
    assert np.allclose(keys(f"{base}/model/R.Heel", ".position"), model[:, k_heel], atol=1e-9)
    heel = keys(f"{base}/measured/R.Heel", ".visible")
    assert heel == [i != 3 for i in range(11)]
    assert keys(f"{base}/residual/R.Heel", ".visible") == heel


def test_markers_never_seen_or_off_the_set_are_named():
    from humanoid.motion.markers import MarkerTrajectories, default_markers

    h = get_model("male", "quaternion")
    marker_set = default_markers(h)
    pos = np.zeros((2, 3, 3))
    pos[:, 1] = np.nan
    measured = MarkerTrajectories([0.0, 0.1], ["R.ASIS", "gone", "extra"], pos, "t.trc")
    rec, view = _recorded(h)
    with pytest.warns(viewer.HiddenMarkerWarning, match="never seen, not drawn: gone.*no model "
                      "marker .*: extra"):  # fmt: skip
        assert view.set_markers(measured, marker_set) == ["R.ASIS", "extra"]
    objects = _paths(rec, "set_object")
    assert "/meshcat/humanoid/markers/measured/extra" in objects
    assert "/meshcat/humanoid/markers/model/extra" not in objects
    assert not any("gone" in p for p in objects)


def _legend_lines(view) -> list[str]:
    import re

    legend = viewer.page_html(view).split('id="legend"')[1].split("</div>\n")[0]
    return re.findall(r"</span>([^<]+)</div>", legend) + re.findall(r"<div>([^<]+)</div>", legend)


def test_the_legend_lists_exactly_the_overlays_drawn(landing):
    h = get_model("male", "quaternion")
    # inverse kinematics: no forces, no feet attached, but markers
    traj = _carried(h, 0.5, 1.0, 11)
    measured, marker_set, _ = _recording(h, traj)
    _, view = _recorded(h)
    with pytest.warns(viewer.HiddenMarkerWarning):
        view.set_markers(measured, marker_set)
    view.animate(traj)
    assert _legend_lines(view) == [
        "centre of mass and its ground projection", "measured markers",
        "model markers (the set, on the body)", "residuals (model to measured marker)",
    ]  # fmt: skip
    # a landing: forces and feet, no markers
    _, view = _recorded(h)
    view.animate(landing)
    assert _legend_lines(view) == [
        "contact forces (at the centre of pressure)", "centre of mass and its ground projection",
        "attached feet", "arrows: 0.5 m per body weight",
    ]  # fmt: skip
    _, view = _recorded(h, viewer.Overlays(com=False, footprints=False))
    view.animate(landing)
    assert [x for x in _legend_lines(view) if "centre of mass" in x or "feet" in x] == []
    _, view = _recorded(h, viewer.Overlays(markers=False))
    view.set_markers(measured, marker_set)  # switched off: nothing drawn, nothing said
    view.animate(traj)
    assert _legend_lines(view) == ["centre of mass and its ground projection"]


def _direction(pose) -> np.ndarray:
    d = pose.target - pose.eye
    return d / np.linalg.norm(d)


@pytest.mark.parametrize("heading", [0.0, np.radians(30.0)])
def test_camera_presets_look_along_the_body_axes(heading):
    """side: along the left-right axis (from the body's right); front: along the walking
    direction (facing the body); top: down, the walk across the view; the preset chosen is the
    camera meshcat is sent (in its scene's axes, y up)."""
    h = get_model("male", "quaternion")
    traj = _carried(h, 3.0, 2.0, 21, heading)
    forward = np.array([np.cos(heading), np.sin(heading), 0.0])
    left = np.array([-np.sin(heading), np.cos(heading), 0.0])
    for preset in viewer.PRESETS:
        rec, view = _recorded(h, None) if preset == "oblique" else (None, None)
        rec = viewer.CommandRecorder()
        view = viewer.SceneView(meshcat.Visualizer(window=rec), h, camera=preset)
        view.animate(traj)
        pose = view.cameras[preset]
        sent = _last(rec, "/Cameras/default/rotated/<object>", "set_property", "position")
        assert np.allclose(sent["value"], [pose.eye[0], pose.eye[2], -pose.eye[1]])
        transform = _last(rec, "/Cameras/default", "set_transform")["matrix"]
        assert np.allclose(np.array(transform).reshape(4, 4), np.eye(4))
        assert np.allclose(pose.project(pose.target), 0.0, atol=1e-12)
    cams = view.cameras
    assert np.allclose(_direction(cams["side"]), left, atol=1e-9)  # seen from the right
    assert np.allclose(_direction(cams["front"]), -forward, atol=1e-9)  # facing the body
    assert _direction(cams["top"])[2] < -0.999  # down
    # top: the walk goes left to right, the body's left up the view
    start, end = cams["top"].project(np.array([traj.q[0, :3], traj.q[-1, :3]]))
    assert end[0] - start[0] > 0.5 and abs(end[1] - start[1]) < 0.05
    assert cams["side"].follow and cams["front"].follow and not cams["top"].follow
    with pytest.raises(hm.HumanoidError, match="unknown camera 'back'"):
        viewer.SceneView(meshcat.Visualizer(window=viewer.CommandRecorder()), h, camera="back")


def test_a_long_walk_keeps_the_body_large_and_top_shows_the_path():
    """A 6 m walk: in the framing presets the body's joints span at least half the view's
    height at every record (the camera following the centre of mass as the page does: by its
    horizontal displacement since the first record), and stay inside the view; in top, every
    record's pelvis and the body at both ends are in the view (square: the narrowest)."""
    h = get_model("male", "quaternion")
    traj = _carried(h, 6.0, 4.0, 41)
    _, view = _recorded(h)
    view.animate(traj)
    data = h.model.createData()
    for preset in ("oblique", "side", "front"):
        for q in traj.q:
            pin.framesForwardKinematics(h.model, data, q)
            joints = np.array([f.translation for f in data.oMf[1:]])
            d = view.followed_point(q) - view.follow_origin
            ndc = view.cameras[preset].shifted([d[0], d[1], 0.0]).project(joints)
            assert np.ptp(ndc[:, 1]) / 2 > 0.5, preset  # of the view's height
            assert np.abs(ndc).max() < 0.9, preset
    top = view.cameras["top"]
    assert np.abs(top.project(traj.q[:, :3])).max() < 0.9
    for q in (traj.q[0], traj.q[-1]):
        pin.framesForwardKinematics(h.model, data, q)
        assert np.abs(top.project(np.array([f.translation for f in data.oMf[1:]]))).max() < 1.0


def test_the_page_carries_the_presets_and_opens_with_the_chosen_one(tmp_path):
    import json
    import re

    h = get_model("male", "quaternion")
    traj = _carried(h, 2.0, 1.0, 11)
    path = viewer.export_html(h, tmp_path / "w.html", traj=traj, camera="side")
    text = path.read_text()
    cameras = json.loads(re.search(r"var cameras = (\{.*?\}\}), origin", text).group(1))
    assert set(cameras) == set(viewer.PRESETS)
    assert 'view = "side"' in text
    for key in ("oblique", "side", "front", "top"):
        assert f'data-view="{key}"' in text


def _page_commands(path) -> list[dict]:
    import base64
    import re

    import umsgpack

    text = path.read_text()
    packed = re.search(r"var humanoidCommands = \[(.*?)\];", text, re.S).group(1)
    return [umsgpack.unpackb(base64.b64decode(x.strip('"'))) for x in packed.split(",") if x]


def test_cli_ik_and_view_draw_the_trial(tmp_path, capsys):
    """``humanoid ik trial.trc --html``, then ``humanoid view ik.mot --markers trial.trc
    --camera top --html``: both pages draw the measured and the fitted markers, the residuals
    between them (a few centimetres: the trial's own offsets), and list them in the legend."""
    from humanoid.cli import main
    from humanoid.motion.markers import write_trc

    h = get_model("male", "quaternion")
    traj = _carried(h, 1.0, 0.5, 6)
    measured, _, _ = _recording(h, traj)
    trc = write_trc(tmp_path / "trial.trc", measured)
    mot, page = tmp_path / "ik.mot", tmp_path / "ik.html"
    assert main(["ik", str(trc), "--model", "adult_male", "-o", str(mot), "--html", str(page),
                 "--quiet"]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "trial.trc: hidden where missing: R.Heel (1 of 6 frames)" in out
    assert "viewer hides" in out
    shown = tmp_path / "view.html"
    with pytest.warns(viewer.HiddenMarkerWarning, match="R.Heel"):
        assert main(["view", str(mot), "--markers", str(trc), "--camera", "top", "--html",
                     str(shown)]) == 0  # fmt: skip
    for path in (page, shown):
        commands = _page_commands(path)
        objects = {c["path"] for c in commands if c["type"] == "set_object"}
        for n in ("R.ASIS", "L.Heel", "head"):
            for kind in ("measured", "model"):
                assert f"/meshcat/humanoid/markers/{kind}/{n}" in objects, (path.name, n)
        anim = next(c for c in commands if c["type"] == "set_animation")
        clips = {a["path"]: a["clip"] for a in anim["animations"]}
        scale = clips["/meshcat/humanoid/markers/residual/R.ASIS/length"]["tracks"][0]["keys"]
        lengths = [k["value"][2] for k in scale]
        assert 0.0 < max(lengths) < 0.06, lengths
        text = path.read_text()
        assert "measured markers" in text and "contact forces" not in text
    assert 'view = "top"' in shown.read_text()
    with pytest.raises(SystemExit):
        main(["view", str(mot), "--camera", "back"])
    assert main(["view", str(BODIES / "adult_male.urdf"), "--markers", str(trc), "--html",
                 str(tmp_path / "x.html")]) == 2  # fmt: skip
    assert "--markers are drawn with a motion" in capsys.readouterr().err


def test_cli_track_draws_the_trial_on_its_clock(tmp_path, capsys):
    """``humanoid track trial.trc --html``: the trial starts at 0.5 s, the run at 0: the page
    draws the trial's markers on the run's clock (the hidden frame where the file has none),
    the residuals from the simulated body's markers a few millimetres to centimetres."""
    from humanoid.cli import main
    from humanoid.motion.markers import MarkerTrajectories, write_trc

    h = get_model("male", "quaternion")
    still = _carried(h, 0.0, 0.15, 16)
    still = type(still)(still.t, np.tile(h.standing_configuration(), (16, 1)), still.v,
                        still.tau, {}, still.energy, still.residual, {})  # fmt: skip
    measured, _, _ = _recording(h, still, missing=("R.Heel", 10))
    measured = MarkerTrajectories(measured.time + 0.5, measured.names, measured.positions)
    trc = write_trc(tmp_path / "trial.trc", measured)
    page = tmp_path / "t.html"
    main(["track", str(trc), "-o", str(tmp_path / "t.npz"), "--html", str(page), "--quiet"])
    assert "hidden where missing: R.Heel (1 of 16 frames)" in capsys.readouterr().out
    anim = next(c for c in _page_commands(page) if c["type"] == "set_animation")
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    base = "/meshcat/humanoid/markers"
    shown = next(t for t in clips[f"{base}/measured/R.Heel"]["tracks"] if t["name"] == ".visible")
    hidden = [k["time"] / 30.0 for k in shown["keys"] if not k["value"]]
    assert hidden == pytest.approx([0.1])  # frame 10 of the trial, at 0.6 s
    scale = clips[f"{base}/residual/L.ASIS/length"]["tracks"][0]["keys"]
    assert 0.0 < max(k["value"][2] for k in scale) < 0.06
