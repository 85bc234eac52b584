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
grid, and the recording (:meth:`SceneView.set_markers`): the measured markers or keypoints, the
same marker set placed on the animated body, and a residual line from each model marker to its
measured one; each can be switched off. The legend lists the overlays the scene draws.

The camera (:class:`CameraPose`, :data:`PRESETS`; this package's page has a button and a key
for each): ``oblique`` (the default: from the front right and above), ``side`` (from the
body's right, looking along the left-right axis, the walk going left to right on screen),
``front`` (facing the body, looking back along the walking direction) and ``top`` (looking
down, the walk left to right). The first three frame the body (it spans :data:`BODY_FRACTION`
of the view's height, ``fov`` :data:`FOV`) and follow its centre of mass (the pelvis without the
com overlay) over the ground, so a long walk stays as large as a short one; ``top`` stands still
and frames the whole path. The walking direction is the followed point's displacement from the
first record to the last (the pelvis' heading when it moves less than 0.5 m). meshcat's own
page (:attr:`LiveViewer.url`) gets the preset's eye but looks at the world's origin: meshcat
has no command for the camera's target, which this package's page sets. Nothing here is
imported by ``import humanoid``.
"""

from __future__ import annotations

import base64
import json
import math
import warnings
from dataclasses import dataclass
from html import escape as html_escape
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from .contacts import cop_on_plane
from .errors import MissingExtra, ViewerError

__all__ = [
    "BODY_FRACTION", "CameraPose", "CommandRecorder", "FOV", "HiddenMarkerWarning", "LiveViewer",
    "Overlays", "PRESETS", "SceneView", "export_html", "humanoid_for", "page_html",
]  # fmt: skip


class HiddenMarkerWarning(UserWarning):
    """The viewer leaves out markers: missing in frames (hidden there), never seen, or without a
    model marker (not in the marker set, or on a frame the body lacks)."""


def _meshcat():
    try:
        import meshcat
        import meshcat.animation
        import meshcat.geometry
    except ImportError as exc:  # pragma: no cover - meshcat is a dependency
        raise MissingExtra(f"the viewer needs meshcat (pip install meshcat): {exc}") from None
    return meshcat


@dataclass(frozen=True)
class Overlays:
    """Which overlays to draw, and the force arrows' scale [m per body weight]."""

    forces: bool = True
    com: bool = True
    footprints: bool = True
    ground: bool = True
    force_scale: float = 0.5
    markers: bool = True


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
          "push": 0x1F77B4, "measured": 0xE377C2, "model_marker": 0x17BECF,
          "residual": 0x303030}  # fmt: skip
FOV = 75.0  # [deg] the camera's vertical field of view (meshcat's, sent anyway)
BODY_FRACTION = 0.6  # the body's share of the view's height in the framing presets
PRESETS = ("oblique", "side", "front", "top")
MARKER_RADIUS = {"measured": 0.014, "model": 0.010}  # [m]
RESIDUAL_RADIUS = 0.003  # [m]


def _three(p) -> list[float]:
    """A point of the world (z up) in three.js's scene axes (meshcat turns its scene -90 deg
    about x: y up)."""
    return [float(p[0]), float(p[2]), float(-p[1])]


@dataclass(frozen=True)
class CameraPose:
    """Where the camera stands and what it looks at, world axes [m]; ``follow``: it moves with
    the body over the ground (by the followed point's horizontal displacement since the first
    record). Its up is the world's z, its vertical field of view :data:`FOV`."""

    eye: np.ndarray
    target: np.ndarray
    follow: bool = True

    def shifted(self, d) -> CameraPose:
        """The pose moved by ``d`` (3,) [m] (the follow camera: ``d`` horizontal)."""
        d = np.asarray(d, dtype=float)
        return CameraPose(self.eye + d, self.target + d, self.follow)

    def project(self, points, aspect: float = 1.0, fov: float = FOV) -> np.ndarray:
        """Points (k, 3) world [m] on the view: (k, 2) normalised device coordinates (x right,
        y up; the view is [-1, 1]^2; a point behind the camera is NaN), as three.js's
        perspective camera projects them (width/height ``aspect``)."""
        back = self.eye - self.target
        back = back / np.linalg.norm(back)
        right = np.cross([0.0, 0.0, 1.0], back)
        right = right / np.linalg.norm(right)
        up = np.cross(back, right)
        rel = np.atleast_2d(points) - self.eye
        depth = -rel @ back
        t = math.tan(math.radians(fov) / 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = (rel @ right) / depth / (t * aspect)
            y = (rel @ up) / depth / t
        out = np.stack([x, y], axis=1)
        out[depth <= 0] = np.nan
        return out


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
        raise ViewerError(f"cannot show geometry {g.name!r}: unsupported or missing {path}")
    fix[:3, :3] = np.diag(np.asarray(g.meshScale, dtype=float))
    return loader.from_file(str(path)), fix


def _arrow_rotation(f: np.ndarray) -> np.ndarray:
    """Rotation taking +Z to the direction of f."""
    n = np.linalg.norm(f)
    if n < 1e-12:
        return np.eye(3)
    return pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), f / n).toRotationMatrix()


def _left_out(measured, names: list[str], times: np.ndarray, positions: np.ndarray,
              marker_set: dict, model) -> tuple[list[int], list[str]]:  # fmt: skip
    """The measured markers to draw (their indices: those seen at least once) and those without
    a model marker, with a :class:`HiddenMarkerWarning` naming what is hidden or left out."""
    seen = np.isfinite(positions).all(axis=2)  # (n, m)
    never = [n for k, n in enumerate(names) if not seen[:, k].any()]
    gaps = [(n, int((~seen[:, k]).sum())) for k, n in enumerate(names)
            if seen[:, k].any() and not seen[:, k].all()]  # fmt: skip
    unplaced = [n for n in names if n not in never and (
        n not in marker_set or not model.existFrame(marker_set[n].frame))]  # fmt: skip
    keep = [k for k, n in enumerate(names) if n not in never]
    said = []
    if gaps:
        said.append("hidden where missing: " + _listed(
            [f"{n} ({c} of {len(times)} frames)" for n, c in gaps]))  # fmt: skip
    if never:
        said.append("never seen, not drawn: " + _listed(never))
    if unplaced:
        said.append("no model marker (not in the marker set, or its frame is not the "
                    "body's): " + _listed(unplaced))  # fmt: skip
    if said:
        warnings.warn(f"{measured.source or 'markers'}: " + "; ".join(said),
                      HiddenMarkerWarning, stacklevel=3)  # fmt: skip
    return keep, unplaced


def _camera_presets(
    path: np.ndarray, lo: float, hi: float, forward: np.ndarray
) -> dict[str, CameraPose]:
    """The presets (see :meth:`SceneView.frame_camera`) for the followed point's path (k, 3),
    the body's frames' heights from ``lo`` to ``hi`` and its walking direction [m]."""
    height = max(1.1 * (hi - lo), 0.5)
    p0 = path[0]
    forward /= np.linalg.norm(forward)
    up = np.array([0.0, 0.0, 1.0])
    left = np.cross(up, forward)
    tan = math.tan(math.radians(FOV) / 2)
    distance = height / BODY_FRACTION / (2 * tan)
    target = np.array([p0[0], p0[1], (lo + hi) / 2])
    oblique = 2.3 * forward - 1.3 * left + 0.9 * up
    oblique /= np.linalg.norm(oblique)
    # top: the path in the (forward, left) axes, 1 m around it
    mean = path[:, :2].mean(axis=0)
    along, across = (path[:, :2] - mean) @ forward[:2], (path[:, :2] - mean) @ left[:2]
    centre = mean + (along.max() + along.min()) / 2 * forward[:2]
    centre = centre + (across.max() + across.min()) / 2 * left[:2]
    half = max(np.ptp(along), np.ptp(across)) / 2 + 1.0
    high = half / tan + (hi - lo)
    ground = np.array([centre[0], centre[1], 0.0])
    return {
        "oblique": CameraPose(target + distance * oblique, target),
        "side": CameraPose(target - distance * left, target),
        "front": CameraPose(target + distance * forward, target),
        "top": CameraPose(ground + high * up - 0.01 * high * left, ground, follow=False),
    }


class _SceneNodes:
    """The scene tree of a :class:`SceneView`: the body's and the overlays' objects, and the
    poses of its arrows and feet (what the view draws, not what it shows when)."""

    vis: Any
    h: Any
    overlays: Overlays
    feet: tuple[str, ...]
    model: Any
    data: Any
    weight: float
    present: set[str]
    # (names, times (n,), positions (n, m, 3), {name: (frame id, offset)} model markers)
    markers: tuple[list[str], np.ndarray, np.ndarray, dict[str, tuple[int, np.ndarray]]] | None

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

    def _frame_path(self, xy: np.ndarray) -> None:
        """A ground that covers a path (x, y of the pelvis) longer than the default."""
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        centre, span = (lo + hi) / 2, hi - lo
        if max(span) < 1.0 or not self.overlays.ground:
            return
        G = _meshcat().geometry
        box = G.Box([span[0] + 3.0, span[1] + 3.0, 0.01])
        material = G.MeshLambertMaterial(color=COLORS["ground"], opacity=0.25, transparent=True)
        self.node("ground").set_object(box, material)
        self.node("ground").set_transform(
            pin.SE3(np.eye(3), np.array([centre[0], centre[1], -0.006])).homogeneous
        )

    @staticmethod
    def _along_z(offset: float = 0.0) -> np.ndarray:
        """meshcat cylinders lie along +Y: turn them to +Z, centred at z = offset."""
        return pin.SE3(pin.utils.rotate("x", np.pi / 2), np.array([0.0, 0.0, offset])).homogeneous

    def _contact_poses(self, forces: dict) -> list[tuple]:
        """The feet's footprints (shown while attached) and the contact force arrows (from each
        foot's centre of pressure, and the floor's total from its own) for one state."""
        out: list[tuple] = []
        ov = self.overlays
        for side in self.feet:
            w = forces.get(side)
            attached = w is not None and np.all(np.isfinite(w))
            sole = self.data.oMf[self.h.sole_id(side)]
            if ov.footprints and self.h.contact_points[side]:
                out.append((("footprints", side), "visible", bool(attached)))
                if attached:
                    self.present.add("footprint")
                    out.append((("footprints", side), "transform", sole.homogeneous))
            if ov.forces:
                show = bool(attached and w is not None and w[2] > 1e-6)
                out.append((("forces", side), "visible", show))
                if show and w is not None:
                    self.present.add("force")
                    cop = cop_on_plane(np.asarray(w), sole.translation)
                    out += self._arrow_pose(("forces", side), np.asarray(w[:3]), tail=cop)
        if ov.forces:  # the floor's total force, at its centre of pressure
            w = forces.get("ground")
            show = w is not None and bool(np.all(np.isfinite(w))) and w[2] > 1e-6
            out.append((("forces", "ground"), "visible", bool(show)))
            if show and w is not None:
                self.present.add("force")
                cop = cop_on_plane(np.asarray(w), np.zeros(3))
                out += self._arrow_pose(("forces", "ground"), np.asarray(w[:3]), tail=cop)
        return out

    def _draw_markers(self, names: list[str], model: dict) -> None:
        """The recording's objects, hidden: a sphere per measured marker, and per marker of
        ``model`` (name -> (frame id, offset)) a sphere and a residual line (unit, along +z)."""
        G = _meshcat().geometry
        measured_material = G.MeshLambertMaterial(color=COLORS["measured"])
        model_material = G.MeshLambertMaterial(color=COLORS["model_marker"])
        line = G.MeshLambertMaterial(color=COLORS["residual"])
        for n in names:
            key = _key(n)
            self.node("markers", "measured", key).set_object(
                G.Sphere(MARKER_RADIUS["measured"]), measured_material
            )
            self.node("markers", "measured", key).set_property("visible", False)
            if n in model:
                self.node("markers", "model", key).set_object(
                    G.Sphere(MARKER_RADIUS["model"]), model_material
                )
                shaft = self.node("markers", "residual", key, "length", "line")
                shaft.set_object(G.Cylinder(1.0, RESIDUAL_RADIUS), line)
                shaft.set_transform(self._along_z(0.5))
                self.node("markers", "residual", key).set_property("visible", False)

    def _marker_poses(self, measured: np.ndarray) -> list:
        """The recording's nodes for its markers as measured at one time (m, 3): measured and
        model markers' positions, the residual lines (from the model marker to the measured one:
        a unit line along +z turned and scaled to the residual), hidden where the measured
        marker is missing."""
        assert self.markers is not None  # called only when a recording is set
        names, _, _, model = self.markers
        out: list[tuple] = []
        for n, m in zip(names, measured, strict=True):
            key = _key(n)
            seen = bool(np.all(np.isfinite(m)))
            out.append((("markers", "measured", key), "visible", seen))
            if seen:
                self.present.add("measured")
                out.append((("markers", "measured", key), "position", [float(x) for x in m]))
            if n not in model:
                continue
            fid, offset = model[n]
            p = self.data.oMf[fid].act(offset)
            self.present.add("model_marker")
            out.append((("markers", "model", key), "position", [float(x) for x in p]))
            out.append((("markers", "residual", key), "visible", seen))
            if seen:
                self.present.add("residual")
                d = m - p
                out += [(("markers", "residual", key), "transform",
                         pin.SE3(_arrow_rotation(d), p).homogeneous),
                        (("markers", "residual", key, "length"), "scale",
                         [1.0, 1.0, max(float(np.linalg.norm(d)), 1e-6)])]  # fmt: skip
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


class SceneView(_SceneNodes):
    """The meshcat scene of one humanoid: body, overlays, poses and animations.

    Args:
        vis: A meshcat ``Visualizer`` (live, or on a :class:`CommandRecorder`).
        h: The :class:`~humanoid.model.Humanoid` to show.
        overlays: What to draw besides the body.
        feet: Contact names that can carry forces (``left``, ``right``), default both.
        camera: The camera preset the view opens with (:data:`PRESETS`).

    Attributes:
        cameras: {preset: :class:`CameraPose`} for the motion shown (the first record's).
        present: The overlays drawn so far (the legend's lines): ``force``, ``push``,
            ``com``, ``footprint``, ``measured``, ``model_marker``, ``residual``.
    """

    def __init__(
        self, vis, h, overlays: Overlays = Overlays(), feet=("left", "right"), camera="oblique"
    ) -> None:
        if camera not in PRESETS:
            raise ViewerError(f"unknown camera {camera!r}; one of {', '.join(PRESETS)}")
        self.vis, self.h, self.overlays, self.feet = vis, h, overlays, tuple(feet)
        self.camera = camera
        self.model = h.model
        self.data = h.model.createData()
        self.gdata = pin.GeometryData(h.visual_model)
        self.weight = h.mass * float(np.linalg.norm(h.model.gravity.linear) or 9.81)
        self.pushes: list[tuple[int, np.ndarray, float, float]] = []
        self.markers = None  # the recording (set_markers; its layout: _SceneNodes.markers)
        self.present: set[str] = set()
        self.timeline = (0.0, 0.0, 1.0)  # (first record [s], animation length [s], speed)
        self.cameras: dict[str, CameraPose] = {}
        self.follow_origin = np.zeros(3)  # the followed point at the first record
        self._build()
        self.frame_camera(np.atleast_2d(h.standing_configuration()))

    def set_pushes(self, pushes) -> None:
        """Pushes to draw as arrows pointing at the pushed point while they act: a list of
        (frame id, force (3,) [N], start [s], duration [s])."""
        self.pushes = list(pushes)
        if self.overlays.forces:
            for i in range(len(self.pushes)):
                self._arrow(("pushes", str(i)), COLORS["push"])

    def set_markers(self, measured, marker_set: dict | None = None) -> list[str]:
        """Draw a recording: measured markers or keypoints (a
        :class:`~humanoid.motion.markers.MarkerTrajectories`, world axes [m], on the
        trajectory's clock), the markers of ``marker_set`` (name -> ``Marker``: a frame of the
        body and an offset in it [m]) that it has placed on the animated body, and a residual
        line from each model marker to its measured one.

        A measured marker is hidden in the frames it is missing from (NaN, or outside its
        recording's time); one never seen is not drawn; one the set does not place (or places
        on a frame the body lacks) is drawn without a model marker. A
        :class:`HiddenMarkerWarning` names them.

        Returns:
            The names of the measured markers drawn.
        """
        if not self.overlays.markers:
            return []
        names, times = list(measured.names), np.asarray(measured.time, dtype=float)
        positions = np.asarray(measured.positions, dtype=float)
        marker_set = marker_set or {}
        keep, unplaced = _left_out(measured, names, times, positions, marker_set, self.model)
        names = [names[k] for k in keep]
        model: dict[str, tuple[int, np.ndarray]] = {}
        for n in names:
            if n not in unplaced:
                m = marker_set[n]
                model[n] = (self.model.getFrameId(m.frame), np.asarray(m.offset, dtype=float))
        self.markers = (names, times, positions[:, keep], model)
        self._draw_markers(names, model)
        return names

    def measured_at(self, t: float | None) -> np.ndarray:
        """The measured markers at time ``t`` [s]: (m, 3) world [m], linear between the
        recording's frames; NaN where missing (at either frame around ``t``) or outside the
        recording."""
        if self.markers is None:
            raise ViewerError("no recording to read: set_markers first")
        names, times, positions, _ = self.markers
        out = np.full((len(names), 3), np.nan)
        if t is None or len(times) == 0 or not times[0] - 1e-9 <= t <= times[-1] + 1e-9:
            return out
        i = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1))
        if i == len(times) - 1 or abs(t - times[i]) < 1e-9:
            return positions[i].copy()
        if abs(times[i + 1] - t) < 1e-9:
            return positions[i + 1].copy()
        s = (t - times[i]) / (times[i + 1] - times[i])
        return (1 - s) * positions[i] + s * positions[i + 1]  # NaN if either is

    # -- camera --------------------------------------------------------------------------
    def followed_point(self, q) -> np.ndarray:
        """The point the camera follows for a configuration: the centre of mass with the com
        overlay, else the root body's first geometry (as the page follows it) [m]."""
        if self.overlays.com:
            return np.array(pin.centerOfMass(self.model, self.data, q))
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, self.h.visual_model, self.gdata)
        for i, g in enumerate(self.h.visual_model.geometryObjects):
            if g.parentJoint == 1:
                return np.array(self.gdata.oMg[i].translation)
        return np.array(self.data.oMi[min(1, self.model.njoints - 1)].translation)

    def frame_camera(self, qs: np.ndarray) -> dict[str, CameraPose]:
        """The camera presets for a motion (configurations (n, nq)), posed at its first one,
        and the camera commands of the chosen one.

        The framing presets look at the middle of the body's height above the followed point,
        from ``BODY_FRACTION``'s distance: the body's height (its frames' vertical extent and
        10 %, at least 0.5 m) over ``BODY_FRACTION`` fills the view's height. ``top`` looks
        down on the middle of the followed point's path from high enough that the path and
        1 m around it fit in the view (square or wider).
        """
        qs = np.atleast_2d(qs)
        step = max(1, len(qs) // 200)  # the path: 200 records or so, and the last
        path = np.array([self.followed_point(q) for q in [*qs[::step], qs[-1]]])
        q0 = qs[0]
        pin.framesForwardKinematics(self.model, self.data, q0)
        z = np.array([f.translation[2] for f in self.data.oMf[1:]])  # (not the universe)
        lo, hi = float(z.min()), float(z.max())
        p0 = path[0]
        self.follow_origin = p0
        walk = path[-1, :2] - p0[:2]
        if np.linalg.norm(walk) >= 0.5:
            forward = np.array([walk[0], walk[1], 0.0])
        else:
            R = self.data.oMi[1].rotation if self.model.njoints > 1 else np.eye(3)
            forward = np.array([R[0, 0], R[1, 0], 0.0])
            if np.linalg.norm(forward) < 1e-6:
                forward = np.array([1.0, 0.0, 0.0])
        self.cameras = _camera_presets(path, lo, hi, forward)
        pose = self.cameras[self.camera]
        self.vis["/Cameras/default"].set_transform(np.eye(4))  # the camera's axes: the scene's
        camera = self.vis["/Cameras/default/rotated/<object>"]
        camera.set_property("position", _three(pose.eye))
        camera.set_property("fov", FOV)
        return self.cameras

    def followed_path(self) -> list[str] | None:
        """The scene-tree path the camera follows: the centre of mass, else the pelvis."""
        if self.overlays.com:
            return ["meshcat", ROOT, "com"]
        root = [g.name for g in self.h.visual_model.geometryObjects if g.parentJoint == 1]
        return ["meshcat", ROOT, "body", root[0]] if root else None

    # -- poses ---------------------------------------------------------------------------
    def frame(self, q, forces: dict | None = None, t: float | None = None) -> list[tuple]:
        """Transforms and properties of every animated node for one state (at time ``t``,
        which decides the pushes shown).

        Returns:
            {node path: ("transform", 4x4) or ("visible", bool) or ("scale", [x, y, z]) or
            ("position", [x, y, z] world [m])}, as a list of (path, kind, value) tuples.
        """
        out: list[tuple] = []
        pin.forwardKinematics(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        pin.updateGeometryPlacements(self.model, self.data, self.h.visual_model, self.gdata)
        for i, g in enumerate(self.h.visual_model.geometryObjects):
            out.append((("body", g.name), "transform", self.gdata.oMg[i].homogeneous))
        ov = self.overlays
        if ov.com:
            self.present.add("com")
            c = pin.centerOfMass(self.model, self.data, q)
            out.append((("com",), "transform", pin.SE3(np.eye(3), c).homogeneous))
            ground = np.array([c[0], c[1], 0.002])
            out.append((("com_ground",), "transform", pin.SE3(np.eye(3), ground).homogeneous))
        out += self._contact_poses(forces or {})
        if ov.forces:
            for i, (fid, f, start, duration) in enumerate(self.pushes):
                on = t is not None and start <= t < start + duration
                out.append((("pushes", str(i)), "visible", bool(on)))
                if on:  # the arrow's tip on the pushed point
                    self.present.add("push")
                    out += self._arrow_pose(
                        ("pushes", str(i)), f, tip=self.data.oMf[fid].translation, gain=PUSH_GAIN
                    )
        if self.markers is not None:
            out += self._marker_poses(self.measured_at(t))
        return out

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
        check_playback(speed, fps)
        t = np.asarray(traj.t)
        if len(t) < 2:
            raise ViewerError("a trajectory needs at least two records to animate")
        n = int(math.floor((t[-1] - t[0]) / speed * fps)) + 1
        if n > MAX_ANIMATION_FRAMES:
            raise ViewerError(
                f"{t[-1] - t[0]:.4g} s at speed {speed:g} and {fps:g} fps is {n:,} animation "
                f"frames, more than {MAX_ANIMATION_FRAMES:,}: lower --fps or raise --speed"
            )
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
                    target.set_property(kind, "vector3", value)
        self.show(*_sample(self.model, traj, t[0], self.feet), t[0])
        self._frame_path(np.asarray(traj.q)[:, :2])
        self.frame_camera(np.asarray(traj.q))
        self.vis.set_animation(anim, play=True, repetitions=LOOPS if loop else 1)
        self.timeline = (float(t[0]), (n - 1) / fps, float(speed))
        return n


def _key(name: str) -> str:
    """A marker's name as one scene-tree path element."""
    return name.replace("/", "_")


def _listed(items, most: int = 8) -> str:
    items = list(items)
    more = f" and {len(items) - most} more" if len(items) > most else ""
    return ", ".join(items[:most]) + more


def _sample(model, traj, time_sim: float, feet) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """State and foot wrenches at a time, interpolated between records on the Lie group."""
    t = np.asarray(traj.t)
    i = int(np.clip(np.searchsorted(t, time_sim, side="right") - 1, 0, len(t) - 2))
    s = float(np.clip((time_sim - t[i]) / (t[i + 1] - t[i]), 0.0, 1.0))
    q = pin.interpolate(model, traj.q[i], traj.q[i + 1], s)
    forces: dict[str, np.ndarray] = {}
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
    raise ViewerError("the trajectory's metadata does not say which body it was recorded on")


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
#views {{ top: 8px; left: auto; right: 8px; }}
#views button.on {{ font-weight: bold; }}
#time {{ font-variant-numeric: tabular-nums; min-width: 7em; }}</style>
</head>
<body>
<div id="meshcat-pane"></div>
<div id="legend" class="panel"><b>{title}</b>{legend}</div>
<div id="views" class="panel">view:
<button data-view="oblique" title="key o">oblique</button>
<button data-view="side" title="key s">side</button>
<button data-view="front" title="key f">front</button>
<button data-view="top" title="key t">top</button>
</div>
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
// the player: play/pause, a time slider and the simulated time; the camera: presets (buttons,
// keys o s f t) and a follow camera that moves with the body over the ground. Positions in
// three.js's scene axes (y up); the camera's parent is at the origin, unturned, in them.
var humanoidPlayer = (function () {{
  var t0 = {t0}, speed = {speed}, duration = {duration};
  var animator = viewer.animator, slider = document.getElementById("slider");
  var button = document.getElementById("play"), label = document.getElementById("time");
  var follow = document.getElementById("follow"), dragging = false;
  var followed = {follow_path};
  var cameras = {cameras}, origin = {origin}, view = {camera};
  function lookup(path) {{  // the node's object, or null before the scene has it (live)
    var node = viewer.scene_tree;
    for (var i = 0; node && i < path.length; i++) node = node.children[path[i]];
    return node ? node.object : null;
  }}
  var THREE = MeshCat.THREE, p = new THREE.Vector3(), last = null, placed = false;
  function shift(d) {{  // move the camera and its orbit target by d (scene axes)
    viewer.camera.position.add(d); viewer.controls.target.add(d); viewer.set_dirty();
  }}
  function setView(name) {{  // a preset, moved with the body since the first record
    var c = cameras[name];
    if (!c) return;
    var d = new THREE.Vector3(0, 0, 0), tracked = followed ? lookup(followed) : null;
    if (tracked) {{
      tracked.getWorldPosition(p);
      if (c.follow) d.set(p.x - origin[0], 0, p.z - origin[2]);
      last = p.clone();
    }}
    viewer.camera.position.fromArray(c.eye).add(d);
    viewer.controls.target.fromArray(c.target).add(d);
    follow.checked = c.follow; view = name; placed = true;
    document.querySelectorAll("#views button").forEach(function (b) {{
      b.className = b.dataset.view === name ? "on" : "";
    }});
    viewer.set_dirty();
  }}
  var own = viewer.set_property.bind(viewer);
  viewer.set_property = function (path, property, value) {{  // once placed, the camera is ours
    if (placed && path[0] === "Cameras" && property === "position") return;
    own(path, property, value);
  }};
  document.querySelectorAll("#views button").forEach(function (b) {{
    b.onclick = function () {{ setView(b.dataset.view); }};
  }});
  var keys = {{ o: "oblique", s: "side", f: "front", t: "top" }};
  document.addEventListener("keydown", function (e) {{
    if (!e.ctrlKey && !e.metaKey && !e.altKey && keys[e.key]) setView(keys[e.key]);
  }});
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
    if (!placed && (tracked || !followed)) setView(view);  // once the scene is there
    if (tracked) {{
      tracked.getWorldPosition(p);
      if (last && follow.checked && Math.abs(p.x - last.x) + Math.abs(p.z - last.z) > 1e-6) {{
        shift(new THREE.Vector3(p.x - last.x, 0, p.z - last.z));
      }}
      last = p.clone();
    }}
    requestAnimationFrame(tick);
  }}
  tick();
  return {{ now: now, simulated: function () {{ return t0 + now() * speed; }},
           setView: setView, view: function () {{ return view; }} }};
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
    "measured": (COLORS["measured"], "measured markers"),
    "model_marker": (COLORS["model_marker"], "model markers (the set, on the body)"),
    "residual": (COLORS["residual"], "residuals (model to measured marker)"),
}


def _legend(view: SceneView) -> str:
    """The legend's HTML: one line per overlay the scene draws (``view.present``)."""
    rows = [
        f'<div><span class="swatch" style="background: #{color:06x}"></span>{text}</div>'
        for key, (color, text) in LEGEND.items()
        if key in view.present
    ]
    if view.present & {"force", "push"}:
        rows.append(f"<div>arrows: {view.overlays.force_scale:g} m per body weight</div>")
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
        legend=_legend(view),
        player="flex" if duration > 0 else "none",
        t0=repr(t0),
        speed=repr(speed),
        duration=repr(duration),
        follow_path=json.dumps(view.followed_path()),
        cameras=json.dumps(
            {
                name: {"eye": _three(c.eye), "target": _three(c.target), "follow": c.follow}
                for name, c in view.cameras.items()
            }
        ),
        origin=json.dumps(_three(view.follow_origin)),
        camera=json.dumps(view.camera),
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
    markers=None,
    marker_set: dict | None = None,
    camera: str = "oblique",
) -> Path:
    """Write one self-contained HTML file: the body, posed at ``q`` or animating ``traj``.

    ``markers`` (:class:`~humanoid.motion.markers.MarkerTrajectories` on the trajectory's
    clock) and ``marker_set`` draw the recording (:meth:`SceneView.set_markers`); ``camera``:
    the preset the page opens with (:data:`PRESETS`). The file inlines meshcat's viewer (about
    0.9 MB) and the scene; it needs no server and loads nothing from the network.
    """
    mc = _meshcat()
    recorder = CommandRecorder()
    view = SceneView(mc.Visualizer(window=recorder), h, overlays, camera=camera)
    if markers is not None:
        view.set_markers(markers, marker_set)
    if traj is not None:
        view.animate(traj, speed=speed, fps=fps)
    else:
        q = h.standing_configuration() if q is None else q
        view.frame_camera(np.atleast_2d(q))
        view.show(q)
    html = page_html(view, title, commands=recorder.packed())
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(html, encoding="utf-8")
    return path


MAX_FPS = 240.0  # [frames/s] a screen shows at most 60-240: more frames only cost time
MAX_SPEED = 1000.0  # [x real time] faster, a run of minutes plays in a frame
# the most frames of one animation: each is a full set of poses sent to the browser; an hour
# at 30 fps is 108,000 (a rate of 1e9 fps never finished building its frames)
MAX_ANIMATION_FRAMES = 200_000


def check_playback(speed: float, fps: float) -> None:
    """Raise HumanoidError unless 0 < ``speed`` <= :data:`MAX_SPEED` (times real time) and
    0 < ``fps`` <= :data:`MAX_FPS` (frames per second)."""
    if not 0.0 < speed <= MAX_SPEED:
        raise ViewerError(f"--speed {speed}: give a playback speed in (0, {MAX_SPEED:g}]")
    if not 0.0 < fps <= MAX_FPS:
        raise ViewerError(f"--fps {fps}: give an animation rate in (0, {MAX_FPS:g}] frames/s")


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
            assert self.proc.stdout is not None  # opened with stdout=PIPE
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
            raise ViewerError("the meshcat server did not start")
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
                assert self.proc.stdin is not None  # opened with stdin=PIPE
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
