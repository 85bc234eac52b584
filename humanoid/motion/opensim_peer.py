"""OpenSim as a peer: the toolkit's body as an OpenSim model, the same motion and loads through
OpenSim 4's inverse dynamics, timed in the same run (and its inverse kinematics, and its
ScaleTool on a static trial: :func:`run_opensim_scale`).

Needs the ``opensim`` package (PyPI, 4.5 or later: a test dependency of the project, not a
runtime one). The body becomes an OpenSim model joint for joint: the free flyer a
``FreeJoint``, a ball joint a ``BallJoint``, a hinge a ``PinJoint`` whose frames turn its
axis onto their Z, every body with the same mass, centre of mass and inertia, gravity along
-z (the toolkit's world, kept: OpenSim allows any gravity). Their coordinates are body-fixed
X-Y-Z angles for the free and ball joints' rotations (and the free joint's translation in the
ground frame), each hinge's angle; :func:`osim_coordinates` writes a motion in them, and
:func:`osim_generalized_forces` writes the toolkit's joint moments as OpenSim's inverse
dynamics reports them (for a ball or free joint, Simbody's mobilizer's: the moment in the
parent's frame), so the two answers compare column by column.
"""

from __future__ import annotations

import math
import time as clock
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import OpenSimError, require
from .loads import Load, write_loads
from .storage import Table, read_storage, write_storage

__all__ = [
    "osim_coordinates",
    "osim_generalized_forces",
    "run_opensim_id",
    "run_opensim_ik",
    "run_opensim_scale",
    "to_osim",
]

_XYZ = ("x", "y", "z")


def _kind(model, j) -> str:
    short = model.joints[j].shortname()
    if "FreeFlyer" in short:
        return "free"
    if "Spherical" in short and "ZYX" not in short:
        return "ball"
    if model.joints[j].nv == 1 and ("Revolute" in short or short.endswith(("RX", "RY", "RZ"))):
        return "hinge"
    raise OpenSimError(f"joint {model.names[j]!r} ({short}) has no OpenSim counterpart here")


def _axis(model, j) -> np.ndarray:
    joint = model.joints[j]
    short = joint.shortname()
    if short.endswith(("RX", "RY", "RZ")):
        a = np.zeros(3)
        a["XYZ".index(short[-1])] = 1.0
        return a
    return np.asarray(joint.extract().axis, dtype=float)


def _turn_z_to(a: np.ndarray) -> np.ndarray:
    """A rotation taking z onto the unit vector a."""
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(z, a)
    s, c = np.linalg.norm(v), float(z @ a)
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    return pin.exp3(v / s * math.atan2(s, c))


def _xyz(R: np.ndarray) -> np.ndarray:
    """Body-fixed X-Y-Z angles of R (OpenSim's orientation convention; at Y = +-90 degrees any
    split of the other two that gives R will do, and scipy's warning is not one)."""
    import warnings

    from scipy.spatial.transform import Rotation

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return Rotation.from_matrix(R).as_euler("XYZ")


def to_osim(h, path: str | Path | None = None, markers: dict | None = None):
    """The body as an ``opensim.Model`` (see the module docstring), with ``markers`` (a marker
    set, :mod:`~humanoid.motion.markers`) on its bodies; written to ``path`` if given."""
    osim = require("opensim", "the OpenSim peer")

    osim.Logger.setLevelString("warn")  # (its tools print every step at "info")
    osim.Logger.removeFileSink()  # (else it writes opensim.log wherever it runs)
    model = h.model
    om = osim.Model()
    om.setName(Path(h.source).stem)
    om.setGravity(osim.Vec3(*model.gravity.linear))
    bodies = {0: om.getGround()}
    for j in range(1, model.njoints):
        I = model.inertias[j]
        Ic = I.inertia  # about the centre of mass, in the body's frame
        mass = max(float(I.mass), 0.0)
        body = osim.Body(model.names[j] + "_body", mass, osim.Vec3(*I.lever),
                         osim.Inertia(Ic[0, 0], Ic[1, 1], Ic[2, 2], Ic[0, 1], Ic[0, 2],
                                      Ic[1, 2]))  # fmt: skip
        om.addBody(body)
        bodies[j] = body
        parent = bodies[model.parents[j]]
        P = model.jointPlacements[j]
        kind = _kind(model, j)
        name = model.names[j]
        if kind == "free":
            joint = osim.FreeJoint(name, parent, osim.Vec3(0), osim.Vec3(0), body, osim.Vec3(0),
                                   osim.Vec3(0))  # fmt: skip
        elif kind == "ball":
            joint = osim.BallJoint(name, parent, osim.Vec3(*P.translation),
                                   osim.Vec3(*_xyz(P.rotation)), body, osim.Vec3(0),
                                   osim.Vec3(0))  # fmt: skip
        else:
            A = _turn_z_to(_axis(model, j))
            joint = osim.PinJoint(name, parent, osim.Vec3(*P.translation),
                                  osim.Vec3(*_xyz(P.rotation @ A)), body, osim.Vec3(0),
                                  osim.Vec3(*_xyz(A)))  # fmt: skip
        om.addJoint(joint)
    for name, m in (markers or {}).items():
        fid = model.getFrameId(m.frame)
        frame = model.frames[fid]
        where = frame.placement.act(np.asarray(m.offset, dtype=float))  # in its joint's frame
        om.addMarker(osim.Marker(name, bodies[frame.parentJoint], osim.Vec3(*where)))
    om.finalizeConnections()
    if path is not None:
        om.printToXML(str(path))
    return om


def _names(om, model):
    """OpenSim's coordinate names per joint, in the toolkit's joint order."""
    osim = require("opensim", "the OpenSim peer")

    out = {}
    for j in range(1, model.njoints):
        joint = om.getJointSet().get(model.names[j])
        coords = [joint.get_coordinates(k) for k in range(joint.numCoordinates())]
        out[j] = [(c.getName(), c.getMotionType() == osim.Coordinate.Translational)
                  for c in coords]  # fmt: skip
    return out


def osim_coordinates(h, om, time, q) -> Table:
    """The motion ``q`` (n, nq) in the OpenSim model's coordinates (radians, metres)."""
    model = h.model
    names = _names(om, model)
    labels, cols = [], []
    for j in range(1, model.njoints):
        kind = _kind(model, j)
        k = model.joints[j].idx_q
        if kind == "hinge":
            cols.append(q[:, k : k + 1])
        else:
            quats = q[:, k + 3 : k + 7] if kind == "free" else q[:, k : k + 4]
            angles = np.array([_xyz(pin.Quaternion(x).normalized().toRotationMatrix())
                               for x in quats])  # fmt: skip
            cols.append(angles)
            if kind == "free":
                cols.append(q[:, k : k + 3])
        labels += [n for n, _ in names[j]]
    return Table(np.asarray(time, dtype=float), labels, np.hstack(cols), False, "coordinates")


def osim_generalized_forces(h, om, time, q, tau) -> Table:
    """The toolkit's generalised forces ``tau`` (n, nv) as the OpenSim model's coordinates'
    (the moment on each X-Y-Z rotation's axis; the free joint's force in the ground frame)."""
    model = h.model
    names = _names(om, model)
    labels, cols = [], []
    for j in range(1, model.njoints):
        kind = _kind(model, j)
        iv, k = model.joints[j].idx_v, model.joints[j].idx_q
        if kind == "hinge":
            cols.append(tau[:, iv : iv + 1])
        else:
            out = np.zeros((len(q), 6 if kind == "free" else 3))
            for i in range(len(q)):
                quat = q[i, k + 3 : k + 7] if kind == "free" else q[i, k : k + 4]
                R = pin.Quaternion(quat).normalized().toRotationMatrix()
                off = 3 if kind == "free" else 0
                # Simbody's ball (and free) mobilizer: its rotational speeds are the angular
                # velocity in the parent's frame, so its forces are the moment there
                out[i, :3] = R @ tau[i, iv + off : iv + off + 3]
                if kind == "free":  # the force in the root's frame at its origin, to ground
                    out[i, 3:] = R @ tau[i, iv : iv + 3]
            cols.append(out)
        labels += [f"{n}_{'force' if translational else 'moment'}"
                   for n, translational in names[j]]  # fmt: skip
    return Table(np.asarray(time, dtype=float), labels, np.hstack(cols), False, "forces")


def run_opensim_id(h, time, q, loads: list[Load], folder: str | Path) -> tuple[Table, float]:
    """OpenSim 4's InverseDynamicsTool on the motion and loads (no filter: the motion is given
    as it is): (its generalised forces, its wall time [s] for the tool's run, model building
    and file writing excluded)."""
    osim = require("opensim", "the OpenSim peer")

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    om = to_osim(h, folder / "body.osim")
    coords = write_storage(folder / "coordinates.mot", osim_coordinates(h, om, time, q))
    feet = {s: h.model.frames[h.sole_id(s)].parentJoint for s in ("left", "right")}
    # in the model's own axes (z up), on the feet's bodies
    grf = write_loads(folder / "grf.mot", loads, y_up=False,
                      bodies={s: h.model.names[j] + "_body" for s, j in feet.items()})  # fmt: skip
    xml = grf.with_suffix(".xml")
    tool = osim.InverseDynamicsTool()
    tool.setModel(om)
    tool.setCoordinatesFileName(str(coords))
    tool.setExternalLoadsFileName(str(xml))
    tool.setLowpassCutoffFrequency(-1.0)
    tool.setStartTime(float(time[0]))
    tool.setEndTime(float(time[-1]))
    tool.setResultsDir(str(folder))
    tool.setOutputGenForceFileName("id.sto")
    tool.setExcludedForces(osim.ArrayStr())
    start = clock.perf_counter()
    if not tool.run():
        raise OpenSimError("OpenSim's InverseDynamicsTool failed")
    elapsed = clock.perf_counter() - start
    return read_storage(folder / "id.sto"), elapsed


def run_opensim_ik(h, markers, marker_set: dict, folder: str | Path,
                   accuracy: float = 1e-5) -> tuple[Table, float]:  # fmt: skip
    """OpenSim 4's InverseKinematicsTool on the marker trajectories (every marker of the set
    at weight 1, as the toolkit weighs them): (its coordinates in radians, its wall time [s]
    for the tool's run)."""
    osim = require("opensim", "the OpenSim peer")

    from .markers import MarkerTrajectories, write_trc

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    names = [n for n in markers.names if n in marker_set]
    om = to_osim(h, folder / "body.osim", {n: marker_set[n] for n in names})
    cols = [markers.names.index(n) for n in names]
    trc = write_trc(folder / "markers.trc",
                    MarkerTrajectories(markers.time, names, markers.positions[:, cols]),
                    y_up=False)  # fmt: skip
    tool = osim.InverseKinematicsTool()
    tool.setModel(om)
    tool.setMarkerDataFileName(str(trc))
    tasks = osim.IKTaskSet()
    for n in names:
        task = osim.IKMarkerTask()
        task.setName(n)
        task.setWeight(marker_set[n].weight)
        task.setApply(True)
        tasks.cloneAndAppend(task)
    tool.set_IKTaskSet(tasks)
    tool.set_accuracy(accuracy)
    tool.setStartTime(float(markers.time[0]))
    tool.setEndTime(float(markers.time[-1]))
    tool.setResultsDir(str(folder))
    tool.setOutputMotionFileName(str(folder / "ik.mot"))
    start = clock.perf_counter()
    if not tool.run():
        raise OpenSimError("OpenSim's InverseKinematicsTool failed")
    elapsed = clock.perf_counter() - start
    return read_storage(folder / "ik.mot"), elapsed


# the OpenSim bodies (the toolkit's joints', ``<joint>_body``) each measurement scales in
# :func:`run_opensim_scale`: one measurement a body
_SCALED_JOINTS = {
    "thigh": ("left_hip", "right_hip"),
    "shank": ("left_knee", "right_knee"),
    "foot": ("left_ankle_flexion", "right_ankle_flexion", "left_ankle_inversion",
             "right_ankle_inversion", "left_mtp", "right_mtp"),
    "trunk": ("lumbar", "thoracic"),
    "pelvis_width": ("root_joint",),
    "upper_arm": ("left_shoulder", "right_shoulder"),
    "forearm": ("left_elbow", "right_elbow"),
}  # fmt: skip


def _text(element, tag: str) -> str:
    """The text of ``element``'s child ``tag`` in a file OpenSim wrote."""
    text = element.findtext(tag)
    if text is None:
        raise OpenSimError(f"OpenSim's scale factors have a <Scale> without <{tag}>")
    return text


def _scale_setup(h, static, names: list[str], measured, mass: float) -> str:
    """The ScaleTool's setup XML: a measurement of each of ``measured``'s pairs, scaling its
    segments' bodies, and a MarkerPlacer task of weight 1 for each marker of ``names``."""
    model = h.model
    measurements = []
    for m in measured:
        joints = [j for j in _SCALED_JOINTS.get(m.name, ()) if model.existJointName(j)]
        pairs = "".join(f"<MarkerPair><markers>{a} {b}</markers></MarkerPair>"
                        for a, b, *_ in m.pairs)  # fmt: skip
        scaled = "".join(f'<BodyScale name="{j}_body"><axes>X Y Z</axes></BodyScale>'
                         for j in joints)  # fmt: skip
        measurements.append(f'<Measurement name="{m.name}"><apply>true</apply><MarkerPairSet>'
                            f"<objects>{pairs}</objects></MarkerPairSet><BodyScaleSet><objects>"
                            f"{scaled}</objects></BodyScaleSet></Measurement>")  # fmt: skip
    tasks = "".join(f'<IKMarkerTask name="{n}"><apply>true</apply><weight>1</weight>'
                    "</IKMarkerTask>" for n in names)  # fmt: skip
    span = f"{float(static.time[0])!r} {float(static.time[-1])!r}"
    return f"""<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000"><ScaleTool name="subject">
<mass>{float(mass)!r}</mass>
<GenericModelMaker><model_file>unscaled.osim</model_file></GenericModelMaker>
<ModelScaler><apply>true</apply><scaling_order>measurements</scaling_order>
<MeasurementSet><objects>{"".join(measurements)}</objects></MeasurementSet>
<marker_file>static.trc</marker_file><time_range>{span}</time_range>
<preserve_mass_distribution>true</preserve_mass_distribution>
<output_model_file>scaled.osim</output_model_file>
<output_scale_file>scale_factors.xml</output_scale_file></ModelScaler>
<MarkerPlacer><apply>true</apply><IKTaskSet><objects>{tasks}</objects></IKTaskSet>
<marker_file>static.trc</marker_file><time_range>{span}</time_range>
<output_motion_file>static_pose.mot</output_motion_file>
<output_model_file>placed.osim</output_model_file>
<output_marker_file>placed_markers.xml</output_marker_file>
<max_marker_movement>-1</max_marker_movement></MarkerPlacer>
</ScaleTool></OpenSimDocument>
"""


def _placer_errors(osim, folder: Path, static, names: list[str], cols: list[int]) -> dict:
    """Each marker's distance [m] from the trial's mean at the MarkerPlacer's static pose."""
    # the MarkerPlacer's pose, on the scaled model with its markers not yet moved
    scaled = osim.Model(str(folder / "scaled.osim"))
    state = scaled.initSystem()
    pose = osim.Storage(str(folder / "static_pose.mot"))
    if pose.isInDegrees():
        scaled.getSimbodyEngine().convertDegreesToRadians(pose)
    labels = pose.getColumnLabels()
    row = pose.getStateVector(0).getData()
    coords = scaled.getCoordinateSet()
    for k in range(1, labels.getSize()):  # (a coordinate's path/value, and its speed)
        label = labels.get(k)
        name = label.split("/")[-2] if label.endswith("/value") else label
        if coords.contains(name):
            coords.get(name).setValue(state, row.get(k - 1), False)
    scaled.realizePosition(state)
    mean = np.nanmean(static.positions[:, cols], axis=0)
    errors = {}
    for i, n in enumerate(names):
        p = scaled.getMarkerSet().get(n).getLocationInGround(state)
        errors[n] = float(np.linalg.norm(np.array([p.get(0), p.get(1), p.get(2)]) - mean[i]))
    return errors


def run_opensim_scale(h, static, marker_set: dict, measured, mass: float,
                      folder: str | Path) -> tuple[dict[str, float], dict[str, float]]:  # fmt: skip
    """OpenSim 4's ScaleTool on a static trial: its ModelScaler with a MeasurementSet of the
    marker pairs ``measured`` used (:class:`~humanoid.motion.scale.Measured`, each scaling its
    segments' bodies along X Y Z, one measurement a body), then its MarkerPlacer (every marker
    of the set at weight 1). Returns (each measurement's scale factor as OpenSim applied it to
    its bodies, each marker's distance [m] at the MarkerPlacer's static pose on the scaled
    model before its markers moved: what OpenSim reports as its marker error)."""
    import xml.etree.ElementTree as ET

    osim = require("opensim", "the OpenSim peer")

    from .markers import MarkerTrajectories, write_trc

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    names = [n for n in static.names if n in marker_set]
    to_osim(h, folder / "unscaled.osim", {n: marker_set[n] for n in names})
    cols = [static.names.index(n) for n in names]
    write_trc(folder / "static.trc",
              MarkerTrajectories(static.time, names, static.positions[:, cols]),
              y_up=False)  # fmt: skip
    setup = folder / "setup_scale.xml"
    text = _scale_setup(h, static, names, measured, mass)
    setup.write_text(text, encoding="utf-8")
    tool = osim.ScaleTool(str(setup))
    if not tool.run():
        raise OpenSimError("OpenSim's ScaleTool failed")
    factors: dict[str, float] = {}
    scales = {_text(x, "segment").strip(): [float(v) for v in _text(x, "scales").split()]
              for x in ET.parse(folder / "scale_factors.xml").iter("Scale")}  # fmt: skip
    for m in measured:
        bodies = [f"{j}_body" for j in _SCALED_JOINTS.get(m.name, ()) if j + "_body" in scales]
        if bodies:
            factors[m.name] = float(np.mean([scales[b][0] for b in bodies]))
    return factors, _placer_errors(osim, folder, static, names, cols)
