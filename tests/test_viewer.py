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
from conftest import SCENES, get_model, landing_run

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
    with pytest.raises(hm.HumanoidError, match="speed and fps must be > 0"):
        view.animate(landing, speed=0.0)


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
