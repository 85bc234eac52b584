"""A browser 3D viewer on meshcat: a model, a pose, or a recorded run with its overlays.

Two outputs, one scene description:

- a live viewer (:class:`LiveViewer`): a meshcat server bound to 127.0.0.1 only, in a child
  process that dies with its parent (:mod:`humanoid._meshcat_server`); it serves this
  package's page (legend, player, follow camera) beside meshcat's own;
- one self-contained HTML file (:func:`export_html`): meshcat's JavaScript inlined and the
  scene commands embedded, so it opens from disk with no server and no network.

Both are fed by the same commands: a meshcat ``Visualizer`` writes into a window object, either
the live server's or a :class:`CommandRecorder` (which also makes the scene testable without a
browser). Overlays: contact forces as arrows (length ``force_scale`` metres per body weight),
the centre of mass and its ground projection, the footprints of the attached feet, the ground
grid; each can be switched off. Nothing here is imported by ``import humanoid``.
"""

from __future__ import annotations

import base64
import json
import math
from dataclasses import dataclass
from html import escape as html_escape
from pathlib import Path

import numpy as np
import pinocchio as pin

from .contacts import cop_on_plane
from .errors import HumanoidError

__all__ = [
    "CommandRecorder", "LiveViewer", "Overlays", "SceneView", "export_html", "humanoid_for",
    "page_html",
]  # fmt: skip


def _meshcat():
    try:
        import meshcat
        import meshcat.animation
        import meshcat.geometry
    except ImportError as exc:  # pragma: no cover - meshcat is a dependency
        raise HumanoidError(f"the viewer needs meshcat (pip install meshcat): {exc}") from None
    return meshcat


@dataclass(frozen=True)
class Overlays:
    """Which overlays to draw, and the force arrows' scale [m per body weight]."""

    forces: bool = True
    com: bool = True
    footprints: bool = True
    ground: bool = True
    force_scale: float = 0.5


class CommandRecorder:
    """A meshcat window that keeps the commands instead of sending them to a server."""

    def __init__(self) -> None:
        self.commands: list[dict] = []

    def send(self, command) -> None:
        self.commands.append(command.lower())

    def packed(self) -> list[bytes]:
        import umsgpack

        return [umsgpack.packb(c) for c in self.commands]


ROOT = "humanoid"
PUSH_GAIN = 10.0  # push arrows are this much longer than contact-force arrows (pushes are small)
LOOPS = 10**6  # "loop": a million repetitions (three.js reads 0 as none, not as forever)
COLORS = {"com": 0xD62728, "force": 0xFF7F0E, "footprint": 0x2CA02C, "ground": 0xB0B0B0,
          "push": 0x1F77B4}  # fmt: skip


def _rgb(rgba) -> int:
    r, g, b = (int(round(255 * float(np.clip(x, 0, 1)))) for x in rgba[:3])
    return (r << 16) | (g << 8) | b


def _geometry(g):
    """A meshcat geometry for a Pinocchio geometry object, and the fixed transform it needs."""
    mc = _meshcat()
    G = mc.geometry
    shape = g.geometry
    kind = type(shape).__name__
    fix = np.eye(4)
    if kind == "Box":
        return G.Box(2.0 * np.asarray(shape.halfSide)), fix
    if kind == "Sphere":
        return G.Sphere(shape.radius), fix
    if kind in ("Cylinder", "Capsule"):  # meshcat cylinders lie along +Y
        fix[:3, :3] = pin.utils.rotate("x", np.pi / 2)
        return G.Cylinder(2.0 * shape.halfLength, shape.radius), fix
    path = Path(g.meshPath)
    loaders = {".stl": G.StlMeshGeometry, ".dae": G.DaeMeshGeometry, ".obj": G.ObjMeshGeometry}
    loader = loaders.get(path.suffix.lower())
    if loader is None or not path.is_file():
        raise HumanoidError(f"cannot show geometry {g.name!r}: unsupported or missing {path}")
    fix[:3, :3] = np.diag(np.asarray(g.meshScale, dtype=float))
    return loader.from_file(str(path)), fix


def _arrow_rotation(f: np.ndarray) -> np.ndarray:
    """Rotation taking +Z to the direction of f."""
    n = np.linalg.norm(f)
    if n < 1e-12:
        return np.eye(3)
    return pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), f / n).toRotationMatrix()


class SceneView:
    """The meshcat scene of one humanoid: body, overlays, poses and animations.

    Args:
        vis: A meshcat ``Visualizer`` (live, or on a :class:`CommandRecorder`).
        h: The :class:`~humanoid.model.Humanoid` to show.
        overlays: What to draw besides the body.
        feet: Contact names that can carry forces (``left``, ``right``), default both.
    """

    def __init__(self, vis, h, overlays: Overlays = Overlays(), feet=("left", "right")) -> None:
        self.vis, self.h, self.overlays, self.feet = vis, h, overlays, tuple(feet)
        self.model = h.model
        self.data = h.model.createData()
        self.gdata = pin.GeometryData(h.visual_model)
        self.weight = h.mass * float(np.linalg.norm(h.model.gravity.linear) or 9.81)
        self.pushes = []
        self.timeline = (0.0, 0.0, 1.0)  # (first record [s], animation length [s], speed)
        self._build()

    # -- scene ---------------------------------------------------------------------------
    def node(self, *path: str):
        return self.vis[ROOT + "/" + "/".join(path)]

    def _build(self) -> None:
        mc = _meshcat()
        G = mc.geometry
        self.vis[ROOT].delete()
        for g in self.h.visual_model.geometryObjects:
            geometry, fix = _geometry(g)
            color = np.asarray(g.meshColor)
            material = G.MeshLambertMaterial(color=_rgb(color), opacity=0.6, transparent=True)
            self.node("body", g.name, "shape").set_object(geometry, material)
            self.node("body", g.name, "shape").set_transform(fix)
        # camera: orbit about the pelvis height, from the front left
        self.vis["/Cameras/default"].set_transform(
            pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.9])).homogeneous
        )
        self.vis["/Cameras/default/rotated/<object>"].set_property("position", [2.3, 0.9, 1.3])
        ov = self.overlays
        self.vis["/Grid"].set_property("visible", ov.ground)
        if ov.ground:
            ground = G.Box([3.0, 3.0, 0.01])
            self.node("ground").set_object(
                ground,
                G.MeshLambertMaterial(color=COLORS["ground"], opacity=0.25, transparent=True),
            )
            self.node("ground").set_transform(
                pin.SE3(np.eye(3), np.array([0, 0, -0.006])).homogeneous
            )
        if ov.com:
            red = G.MeshLambertMaterial(color=COLORS["com"])
            self.node("com").set_object(G.Sphere(0.035), red)
            disc = G.Cylinder(0.004, 0.04)
            self.node("com_ground", "disc").set_object(disc, red)
            self.node("com_ground", "disc").set_transform(self._along_z())
        if ov.forces:
            for side in (*self.feet, "ground"):  # ground: the floor's total force, at its CoP
                self._arrow(("forces", side), COLORS["force"])
        if ov.footprints:
            green = G.MeshLambertMaterial(color=COLORS["footprint"], opacity=0.5, transparent=True)
            for side in self.feet:
                if not self.h.contact_points[side]:
                    continue  # no sole points, no footprint
                lo, hi = self.h.sole_box(side)
                box = G.Box([hi[0] - lo[0], hi[1] - lo[1], 0.004])
                self.node("footprints", side, "box").set_object(box, green)
                centre = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 0.002])
                self.node("footprints", side, "box").set_transform(
                    pin.SE3(np.eye(3), centre).homogeneous
                )
                self.node("footprints", side).set_property("visible", False)

    def _arrow(self, path: tuple, color: int) -> None:
        """A hidden unit arrow along +Z at ``path``; its child ``length`` is scaled."""
        G = _meshcat().geometry
        material = G.MeshLambertMaterial(color=color)
        shaft = self.node(*path, "length", "shaft")
        shaft.set_object(G.Cylinder(1.0, 0.018), material)
        shaft.set_transform(self._along_z(0.5))
        head = self.node(*path, "length", "head")
        head.set_object(G.Cylinder(0.12, 0.0, radiusTop=0.0, radiusBottom=0.045), material)
        head.set_transform(self._along_z(1.0))
        self.node(*path).set_property("visible", False)

    def set_pushes(self, pushes) -> None:
        """Pushes to draw as arrows pointing at the pushed point while they act: a list of
        (frame id, force (3,) [N], start [s], duration [s])."""
        self.pushes = list(pushes)
        if self.overlays.forces:
            for i in range(len(self.pushes)):
                self._arrow(("pushes", str(i)), COLORS["push"])

    def _frame_path(self, xy: np.ndarray) -> None:
        """Ground and camera that cover a path (x, y of the pelvis) longer than the default."""
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        centre, span = (lo + hi) / 2, hi - lo
        if max(span) < 1.0:
            return
        if self.overlays.ground:
            G = _meshcat().geometry
            box = G.Box([span[0] + 3.0, span[1] + 3.0, 0.01])
            material = G.MeshLambertMaterial(color=COLORS["ground"], opacity=0.25, transparent=True)
            self.node("ground").set_object(box, material)
            self.node("ground").set_transform(
                pin.SE3(np.eye(3), np.array([centre[0], centre[1], -0.006])).homogeneous
            )
        self.vis["/Cameras/default"].set_transform(
            pin.SE3(np.eye(3), np.array([centre[0], centre[1], 0.9])).homogeneous
        )
        distance = 1.0 + 0.6 * max(span)
        self.vis["/Cameras/default/rotated/<object>"].set_property(
            "position", [distance, 0.5 * distance, 1.5 * distance]
        )

    def followed_path(self) -> list[str] | None:
        """The scene-tree path the camera follows: the centre of mass, else the pelvis."""
        if self.overlays.com:
            return ["meshcat", ROOT, "com"]
        root = [g.name for g in self.h.visual_model.geometryObjects if g.parentJoint == 1]
        return ["meshcat", ROOT, "body", root[0]] if root else None

    @staticmethod
    def _along_z(offset: float = 0.0) -> np.ndarray:
        """meshcat cylinders lie along +Y: turn them to +Z, centred at z = offset."""
        return pin.SE3(pin.utils.rotate("x", np.pi / 2), np.array([0.0, 0.0, offset])).homogeneous

    # -- poses ---------------------------------------------------------------------------
    def frame(self, q, forces: dict | None = None, t: float | None = None) -> dict[str, tuple]:
        """Transforms and properties of every animated node for one state (at time ``t``,
        which decides the pushes shown).

        Returns:
            {node path: ("transform", 4x4) or ("visible", bool) or ("scale", [x, y, z])}, as a
            list of (path, kind, value) tuples.
        """
        out = []
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        pin.updateGeometryPlacements(self.model, self.data, self.h.visual_model, self.gdata)
        for i, g in enumerate(self.h.visual_model.geometryObjects):
            out.append((("body", g.name), "transform", self.gdata.oMg[i].homogeneous))
        ov = self.overlays
        if ov.com:
            c = pin.centerOfMass(self.model, self.data, q)
            out.append((("com",), "transform", pin.SE3(np.eye(3), c).homogeneous))
            ground = np.array([c[0], c[1], 0.002])
            out.append((("com_ground",), "transform", pin.SE3(np.eye(3), ground).homogeneous))
        forces = forces or {}
        for side in self.feet:
            w = forces.get(side)
            attached = w is not None and np.all(np.isfinite(w))
            sole = self.data.oMf[self.h.sole_id(side)]
            if ov.footprints:
                out.append((("footprints", side), "visible", bool(attached)))
                if attached:
                    out.append((("footprints", side), "transform", sole.homogeneous))
            if ov.forces:
                show = bool(attached and w[2] > 1e-6)
                out.append((("forces", side), "visible", show))
                if show:
                    cop = cop_on_plane(np.asarray(w), sole.translation)
                    out += self._arrow_pose(("forces", side), np.asarray(w[:3]), tail=cop)
        if ov.forces:
            w = forces.get("ground")
            show = w is not None and bool(np.all(np.isfinite(w))) and w[2] > 1e-6
            out.append((("forces", "ground"), "visible", bool(show)))
            if show:
                cop = cop_on_plane(np.asarray(w), np.zeros(3))
                out += self._arrow_pose(("forces", "ground"), np.asarray(w[:3]), tail=cop)
            for i, (fid, f, start, duration) in enumerate(self.pushes):
                on = t is not None and start <= t < start + duration
                out.append((("pushes", str(i)), "visible", bool(on)))
                if on:  # the arrow's tip on the pushed point
                    out += self._arrow_pose(
                        ("pushes", str(i)), f, tip=self.data.oMf[fid].translation, gain=PUSH_GAIN
                    )
        return out

    def _arrow_pose(self, path: tuple, f: np.ndarray, tail=None, tip=None, gain=1.0) -> list:
        """Transform and scale of the arrow at ``path`` for a force f [N] (``gain`` times
        0.5 m per body weight by default, at least 1 mm), starting at ``tail`` or ending at
        ``tip``."""
        length = max(gain * self.overlays.force_scale * np.linalg.norm(f) / self.weight, 1e-3)
        if tip is not None:
            tail = tip - length * f / np.linalg.norm(f)
        return [(path, "transform", pin.SE3(_arrow_rotation(f), tail).homogeneous),
                ((*path, "length"), "scale", [1.0, 1.0, length])]  # fmt: skip

    def show(self, q, forces: dict | None = None, t: float | None = None) -> None:
        """Put the scene in one state."""
        for path, kind, value in self.frame(q, forces, t):
            node = self.node(*path)
            if kind == "transform":
                node.set_transform(value)
            else:
                node.set_property(kind, value)

    def animate(self, traj, speed: float = 1.0, fps: float = 30.0, loop: bool = True) -> int:
        """Send a Trajectory as a meshcat animation, played ``speed`` times real time.

        Returns:
            The number of animation frames.
        """
        mc = _meshcat()
        if speed <= 0 or fps <= 0:
            raise HumanoidError(f"speed and fps must be > 0, got speed {speed}, fps {fps}")
        t = np.asarray(traj.t)
        if len(t) < 2:
            raise HumanoidError("a trajectory needs at least two records to animate")
        n = int(math.floor((t[-1] - t[0]) / speed * fps)) + 1
        self.set_pushes(_pushes(self.model, traj.metadata))
        anim = mc.animation.Animation(default_framerate=fps)
        for k in range(n):
            time_sim = t[0] + k * speed / fps
            q, forces = _sample(self.model, traj, time_sim, self.feet)
            for path, kind, value in self.frame(q, forces, time_sim):
                target = anim.at_frame(self.vis, k)[ROOT + "/" + "/".join(path)]
                if kind == "transform":
                    target.set_transform(value)
                elif kind == "visible":
                    target.set_property("visible", "boolean", value)
                else:
                    target.set_property("scale", "vector3", value)
        self.show(*_sample(self.model, traj, t[0], self.feet), t[0])
        self._frame_path(np.asarray(traj.q)[:, :2])
        self.vis.set_animation(anim, play=True, repetitions=LOOPS if loop else 1)
        self.timeline = (float(t[0]), (n - 1) / fps, float(speed))
        return n


def _sample(model, traj, time_sim: float, feet):
    """State and foot wrenches at a time, interpolated between records on the Lie group."""
    t = np.asarray(traj.t)
    i = int(np.clip(np.searchsorted(t, time_sim, side="right") - 1, 0, len(t) - 2))
    s = float(np.clip((time_sim - t[i]) / (t[i + 1] - t[i]), 0.0, 1.0))
    q = pin.interpolate(model, traj.q[i], traj.q[i + 1], s)
    forces = {}
    for side in (*feet, "ground"):
        if side in traj.forces:
            a, b = traj.forces[side][i], traj.forces[side][i + 1]
            forces[side] = (
                (1 - s) * a + s * b if np.all(np.isfinite(a)) and np.all(np.isfinite(b)) else a
            )
    return q, forces


def _pushes(model, meta) -> list[tuple]:
    """(frame id, force, start, duration) of the pushes of a trajectory's scene."""
    out = []
    for p in meta.get("scene", {}).get("effects", {}).get("pushes", []):
        if model.existFrame(p["frame"]) and np.linalg.norm(p["force"]) > 0:
            out.append((model.getFrameId(p["frame"]), np.asarray(p["force"], dtype=float),
                        float(p["start"]), float(p["duration"])))  # fmt: skip
    return out


def humanoid_for(traj):
    """The Humanoid a trajectory was recorded on (from its metadata: the body's recipe, which
    carries the URDF text or a robot's name; runs saved before recipes existed name a file or
    the body parameters)."""
    from .anthropometry import BodyParameters
    from .body import build_urdf
    from .model import load, load_recipe

    meta = traj.metadata
    if isinstance(meta.get("body"), dict):
        return load_recipe(meta["body"])
    mode = meta.get("ball_joints", "quaternion")
    body = meta.get("scene", {}).get("body", {})
    if meta.get("model", "<string>") != "<string>":
        return load(Path(meta["model"]), ball_joints=mode)
    if "height" in body:
        params = BodyParameters(
            body["height"], body["mass"], body["sex"], body.get("segment_lengths", {})
        )
        return load(build_urdf(params), ball_joints=mode)
    raise HumanoidError("the trajectory's metadata does not say which body it was recorded on")


HTML = """<!DOCTYPE html>
<html>
<head><meta charset="utf-8"><title>{title}</title>
<style>body {{ margin: 0; font: 13px sans-serif; }}
#meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
.panel {{ position: absolute; left: 8px; background: rgba(255,255,255,0.85); color: #222;
padding: 6px 10px; border-radius: 4px; }}
#legend {{ top: 8px; }} #legend div {{ margin: 2px 0; }}
#legend span.swatch {{ display: inline-block; width: 12px; height: 12px; margin-right: 6px;
vertical-align: middle; border-radius: 2px; }}
#player {{ bottom: 8px; right: 8px; display: flex; align-items: center; gap: 8px; }}
#player input[type=range] {{ flex: 1; }}
#time {{ font-variant-numeric: tabular-nums; min-width: 7em; }}</style>
</head>
<body>
<div id="meshcat-pane"></div>
<div id="legend" class="panel"><b>{title}</b>{legend}</div>
<div id="player" class="panel" style="display: {player}">
<button id="play">pause</button>
<input id="slider" type="range" min="0" max="{duration}" step="0.001" value="0">
<span id="time"></span>
<label><input id="follow" type="checkbox" checked> follow</label>
</div>
{viewer_script}
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
{feed}
// the player: play/pause, a time slider and the simulated time; the camera follows the body
var humanoidPlayer = (function () {{
  var t0 = {t0}, speed = {speed}, duration = {duration};
  var animator = viewer.animator, slider = document.getElementById("slider");
  var button = document.getElementById("play"), label = document.getElementById("time");
  var follow = document.getElementById("follow"), dragging = false;
  var followed = {follow_path};
  function lookup(path) {{  // the node's object, or null before the scene has it (live)
    var node = viewer.scene_tree;
    for (var i = 0; node && i < path.length; i++) node = node.children[path[i]];
    return node ? node.object : null;
  }}
  var THREE = MeshCat.THREE, p = new THREE.Vector3(), last = null;
  function shift(dx, dy) {{  // move the camera and its orbit target by (dx, dy, 0), world axes
    var parent = viewer.camera.parent;
    var a = parent.worldToLocal(new THREE.Vector3(0, 0, 0));
    var b = parent.worldToLocal(new THREE.Vector3(dx, dy, 0));
    var d = b.sub(a);
    viewer.camera.position.add(d); viewer.controls.target.add(d); viewer.set_dirty();
  }}
  function now() {{ return animator.actions.length ? animator.actions[0].time : 0; }}
  button.onclick = function () {{
    if (animator.playing) {{ animator.pause(); }} else {{ animator.play(); }}
  }};
  slider.oninput = function () {{ dragging = true; animator.seek(parseFloat(slider.value)); }};
  slider.onchange = function () {{ dragging = false; }};
  function tick() {{
    var t = now();
    if (!dragging) slider.value = t;
    label.textContent = "t = " + (t0 + t * speed).toFixed(2) + " s";
    button.textContent = animator.playing ? "pause" : "play";
    var tracked = followed ? lookup(followed) : null;
    if (tracked) {{
      tracked.getWorldPosition(p);
      if (!last) {{  // look at the followed point from where the camera stands
        viewer.controls.target.copy(viewer.camera.parent.worldToLocal(p.clone()));
        viewer.set_dirty();
      }} else if (follow.checked && Math.abs(p.x - last.x) + Math.abs(p.y - last.y) > 1e-6) {{
        shift(p.x - last.x, p.y - last.y);
      }}
      last = p.clone();
    }}
    requestAnimationFrame(tick);
  }}
  tick();
  return {{ now: now, simulated: function () {{ return t0 + now() * speed; }} }};
}})();
window.humanoidReady = true;
</script>
</body>
</html>
"""

LEGEND = {  # overlay: (colour, what it shows)
    "force": (COLORS["force"], "contact forces (at the centre of pressure)"),
    "push": (COLORS["push"], f"pushes (tip on the pushed point; {PUSH_GAIN:g}x longer)"),
    "com": (COLORS["com"], "centre of mass and its ground projection"),
    "footprint": (COLORS["footprint"], "attached feet"),
}


def _legend(overlays: Overlays, pushes: bool) -> str:
    """The legend's HTML: one line per overlay shown."""
    shown = {"force": overlays.forces, "push": overlays.forces and pushes,
             "com": overlays.com, "footprint": overlays.footprints}  # fmt: skip
    rows = [
        f'<div><span class="swatch" style="background: #{color:06x}"></span>{text}</div>'
        for key, (color, text) in LEGEND.items()
        if shown[key]
    ]
    if overlays.forces:
        rows.append(f"<div>arrows: {overlays.force_scale:g} m per body weight</div>")
    return "".join(rows)


EMBEDDED = """var humanoidCommands = [{commands}];
function humanoidDecode(b64) {{
  var bin = atob(b64); var out = new Uint8Array(bin.length);
  for (var i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}}
humanoidCommands.forEach(function (c) {{ viewer.handle_command_bytearray(humanoidDecode(c)); }});"""


def page_html(view: SceneView, title: str = "humanoid", commands: list[bytes] | None = None) -> str:
    """The viewer page of a scene: meshcat's viewer with the legend, and the player when the
    scene animates.

    With ``commands`` (a :class:`CommandRecorder`'s packed commands) the page is self-contained:
    meshcat's JavaScript and the scene are inlined. Without, it is the live page: it loads
    meshcat from the server that serves it and takes the scene from that server's websocket.
    """
    t0, duration, speed = view.timeline
    if commands is None:
        viewer_script = '<script src="/static/main.min.js"></script>'
        feed = "viewer.connect();"
    else:
        mc = _meshcat()
        mainjs = (Path(mc.__file__).parent / "viewer" / "dist" / "main.min.js").read_text(
            encoding="utf-8"
        )
        viewer_script = "<script>" + mainjs.replace("</script>", "<\\/script>") + "</script>"
        packed = ",".join('"' + base64.b64encode(b).decode("ascii") + '"' for b in commands)
        feed = EMBEDDED.format(commands=packed)
    return HTML.format(
        title=html_escape(title),
        legend=_legend(view.overlays, bool(view.pushes)),
        player="flex" if duration > 0 else "none",
        t0=repr(t0),
        speed=repr(speed),
        duration=repr(duration),
        follow_path=json.dumps(view.followed_path()),
        viewer_script=viewer_script,
        feed=feed,
    )


def export_html(
    h,
    path,
    traj=None,
    q=None,
    overlays: Overlays = Overlays(),
    speed: float = 1.0,
    fps: float = 30.0,
    title: str = "humanoid",
) -> Path:
    """Write one self-contained HTML file: the body, posed at ``q`` or animating ``traj``.

    The file inlines meshcat's viewer (about 0.9 MB) and the scene; it needs no server and
    loads nothing from the network.
    """
    mc = _meshcat()
    recorder = CommandRecorder()
    view = SceneView(mc.Visualizer(window=recorder), h, overlays)
    if traj is not None:
        view.animate(traj, speed=speed, fps=fps)
    else:
        view.show(h.standing_configuration() if q is None else q)
    html = page_html(view, title, commands=recorder.packed())
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(html, encoding="utf-8")
    return path


class LiveViewer:
    """A meshcat server on 127.0.0.1 only, in a child process that dies with this process.

    Use as a context manager; ``vis`` is the meshcat Visualizer. The server serves two pages:
    ``page_url``, this package's page (legend, player and follow camera, once :meth:`publish`
    has written it), and ``url``, meshcat's own page.
    """

    def __init__(self, timeout: float = 20.0) -> None:
        import subprocess
        import sys
        import tempfile
        import threading

        mc = _meshcat()
        self._pages = tempfile.TemporaryDirectory(prefix="humanoid-view-")
        self.proc = subprocess.Popen(
            [sys.executable, "-u", "-m", "humanoid._meshcat_server", "--pages", self._pages.name],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        # the server prints two lines; a watchdog stops the wait if it never does
        watchdog = threading.Timer(timeout, self.proc.kill)
        watchdog.start()
        zmq_url = web_url = None
        try:
            for line in self.proc.stdout:
                if line.startswith("zmq_url="):
                    zmq_url = line.split("=", 1)[1].strip()
                elif line.startswith("web_url="):
                    web_url = line.split("=", 1)[1].strip()
                if zmq_url and web_url:
                    break
        finally:
            watchdog.cancel()
        if zmq_url is None or web_url is None:
            self.close()
            raise HumanoidError("the meshcat server did not start")
        self.url = web_url
        self.page_url = web_url.split("/static/")[0] + "/humanoid/"
        import contextlib
        import io

        with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL itself
            self.vis = mc.Visualizer(zmq_url=zmq_url)

    def publish(self, view: SceneView, title: str = "humanoid") -> str:
        """Write this package's page for ``view`` (legend, player, follow camera) on the server;
        returns its URL."""
        (Path(self._pages.name) / "index.html").write_text(page_html(view, title), "utf-8")
        return self.page_url

    def close(self) -> None:
        """Stop the server (closing its stdin makes it exit; then make sure)."""
        if self.proc.poll() is None:
            try:
                self.proc.stdin.close()
                self.proc.wait(timeout=5)
            except Exception:  # noqa: BLE001 - make sure it is gone below
                pass
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self._pages.cleanup()

    def __enter__(self) -> LiveViewer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
