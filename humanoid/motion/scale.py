"""Scaling the body to a subject from a static trial, as OpenSim's ScaleTool does.

A lab records the subject standing still with every marker on (the **static trial**); the
body is made theirs in three steps (:func:`scale_body`):

1. **Measure** (OpenSim's ModelScaler, measurement-based): each :class:`Measurement` is a set
   of marker pairs (a limb's pairs on both sides, averaged: the body is symmetric). A pair's
   ratio is its experimental distance (the mean over the static frames of the distance between
   the two measured markers, frames where either is missing left out) over the same two
   markers' distance on the unscaled body standing (its joints at zero, OpenSim's default
   pose); the measurement's factor is the mean of its pairs' ratios. Each measurement lists
   alternatives, the first whose markers the trial and the marker set both have is used: the
   joint centres of the default set (``right_hip`` ... : a lab's computed joint centres,
   which span exactly the body's segments), then OpenSim gait2354's landmarks (``R.ASIS``,
   ``R.Knee.Lat`` ...), then Vicon Plug-in Gait's (``RASI``, ``RKNE`` ...), then the cluster
   set's (``RLFC``, ``RLMAL``, ``RCAL``: :mod:`~humanoid.motion.marker_sets`). A segment that
   no measurement reaches keeps the stature scaling, and is reported
   (:attr:`ScaleResult.unmeasured`).
2. **Build** the body through :class:`~humanoid.anthropometry.BodyParameters`: each measured
   segment's length is the factor times its length on the unscaled body; its mass the
   subject's (de Leva's fractions). The stature follows the measured chain (sole to vertex,
   :data:`~humanoid.anthropometry.CHAIN`): the chain's unmeasured elements (ankle height,
   head) keep their share of it that the unscaled body has, so the stature is the measured
   elements' sum over one minus that share. A stature given instead is kept, the unmeasured
   elements closing the chain to it (and a warning if it is 2 % off the markers').
   Widths (hips, shoulders, feet) follow the stature, as the toolkit's bodies are built.
3. **Place the markers** (OpenSim's MarkerPlacer): the marker set is carried onto the scaled
   body (each marker's offset scaled with its segment: lengths along it, the stature across
   it; the pelvis's by the pelvis width if measured), the body is fitted to the static
   trial's mean pose (:func:`~humanoid.motion.ik.inverse_kinematics` on the markers averaged
   over the frames), and every marker not flagged ``fixed`` is moved to where it was
   measured, in its frame.

The markers' residuals are reported before scaling (the unscaled body and its set), scaled
(the carried set) and placed (the set moved), each the body fitted to the static trial's
frames (ten of them at most, evenly spread), so that a marker that does not fit says where.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ..errors import ScalingError
from .markers import Marker, MarkerTrajectories, default_markers, marker_positions
from .scale_walk import MOVING, joint_centres, movement, pair_distances, picked

if TYPE_CHECKING:
    from ..anthropometry import BodyParameters
    from ..model import Humanoid

__all__ = [
    "MEASUREMENTS",
    "Measured",
    "Measurement",
    "ScaleResult",
    "ScaleWarning",
    "body_parameters_of",
    "scale_body",
    "with_ranges",
    "MODES",
]

MODES = ("auto", "static", "walk")
WALK_FRAMES = 60  # a walk's frames fitted to measure, place and report at most
STILL = 0.01  # [m]: a marker whose position's standard deviation is above this moved
FACTOR_RANGE = (0.5, 2.0)  # a factor outside it is a unit or marker-name mistake
SIDES_AGREE = 0.1  # a measurement's pairs further apart than this (relative) are reported
HEIGHT_AGREE = 0.02  # a given stature this far (relative) from the markers' is reported


class ScaleWarning(UserWarning):
    """Scaling met something it worked around: a marker missing or moving in the static trial,
    a measurement made on one side only or whose sides disagree, a segment left unmeasured."""


@dataclass(frozen=True)
class Measurement:
    """Marker pairs whose distances scale segments (OpenSim's ``Measurement``).

    Attributes:
        name: Its name (``thigh``, ``trunk``, ``pelvis_width`` ...).
        segments: The lengths of :class:`~humanoid.anthropometry.BodyParameters` it sets
            (none: measured and reported; ``pelvis_width`` scales the pelvis's markers).
        alternatives: Sets of marker pairs, in order of preference: the first with a pair
            whose markers the static trial and the marker set both have is used.
    """

    name: str
    segments: tuple[str, ...]
    alternatives: tuple[tuple[tuple[str, str], ...], ...]


def _sided(*pairs: tuple[str, str]) -> tuple[tuple[str, str], ...]:
    """Each pair written for the right side (``right_``, ``R.``, ``R``) and its left twin."""

    def left(name: str) -> str:
        for r, lft in (("right_", "left_"), ("R.", "L."), ("R", "L")):
            if name.startswith(r):
                return lft + name[len(r) :]
        return name

    return tuple(p for a, b in pairs for p in ((a, b), (left(a), left(b))))


# joint centres (the default set's), gait2354's landmarks, Plug-in Gait's, the cluster set's
MEASUREMENTS = (
    Measurement("thigh", ("thigh",), (
        _sided(("right_hip", "right_knee")), _sided(("R.ASIS", "R.Knee.Lat")),
        _sided(("RASI", "RKNE")), _sided(("RASI", "RLFC")))),
    Measurement("shank", ("shank",), (
        _sided(("right_knee", "right_ankle")), _sided(("R.Knee.Lat", "R.Ankle.Lat")),
        _sided(("RKNE", "RANK")), _sided(("RLFC", "RLMAL")))),
    Measurement("foot", ("foot",), (
        _sided(("R.Heel", "R.Toe.Tip")), _sided(("RHEE", "RTOE")), _sided(("RCAL", "RMT1")))),
    Measurement("trunk", ("pelvis", "abdomen", "thorax"), (
        (("pelvis", "neck"),), _sided(("R.ASIS", "R.Acromium")), _sided(("RASI", "RSHO")))),
    Measurement("pelvis_width", (), (
        (("right_hip", "left_hip"),), (("R.ASIS", "L.ASIS"),), (("RASI", "LASI"),))),
    Measurement("upper_arm", ("upper_arm",), (
        _sided(("right_shoulder", "right_elbow")), _sided(("R.Acromium", "R.Elbow")),
        _sided(("RSHO", "RELB")))),
    Measurement("forearm", ("forearm",), (
        _sided(("right_elbow", "right_wrist")), _sided(("R.Elbow", "R.Wrist.Lat")),
        _sided(("RELB", "RWRA")))),
)  # fmt: skip

# the lengths a static trial can set (BodyParameters' segment_lengths)
LENGTHS = ("head", "thorax", "abdomen", "pelvis", "upper_arm", "forearm", "hand", "thigh",
           "shank", "foot", "ankle_height")  # fmt: skip
# a joint's body's segment, by the joint's name without its side
_SEGMENT_OF = {"root_joint": "pelvis", "lumbar": "abdomen", "thoracic": "thorax", "neck": "head",
               "hip": "thigh", "knee": "shank", "ankle": "foot", "mtp": "foot",
               "shoulder": "upper_arm", "elbow": "forearm", "wrist": "hand"}  # fmt: skip


@dataclass
class Measured:
    """A measurement as made. ``pairs``: (marker, marker, experimental distance [m], the
    unscaled body's [m], ratio) for each pair used; ``factor``: their ratios' mean;
    ``segments``: the lengths it set."""

    name: str
    segments: tuple[str, ...]
    pairs: list[tuple[str, str, float, float, float]]
    factor: float


@dataclass
class ScaleResult:
    """What :func:`scale_body` made, and what it measured.

    Attributes:
        params: The scaled body's parameters. body: The scaled body (a
            :class:`~humanoid.model.Humanoid`). urdf: Its URDF text.
        marker_set: The markers placed on it (write it with
            :func:`~humanoid.motion.markers.write_markers`).
        measured: Each measurement made (:class:`Measured`), in the set's order.
        unmeasured: The lengths no measurement set, each with why (they keep the stature
            scaling).
        lengths: Each length of :data:`LENGTHS`: (the unscaled body's, the scaled one's) [m].
        height: (the unscaled body's stature, the scaled one's) [m].
        pose: The scaled body fitted to the static trial's mean pose (nq,).
        moved: How far each placed marker moved from where it was carried [m].
        fits: The static trial fitted by ``"unscaled"`` (the body and set given), ``"scaled"``
            (the scaled body, the set carried onto it) and ``"placed"`` (the markers placed):
            :class:`~humanoid.motion.ik.IKResult` each.
        source: The static trial's file.
        mode: ``"static"`` or ``"walk"`` (:func:`scale_body`'s ``mode``, as used).
        movement: How far the trial's markers move, the median over them [m]
            (:func:`~humanoid.motion.scale_walk.movement`).
        joint_centres: A pipeline's joint centres read as the set's ({the set's name: the
            trial's label}, :func:`~humanoid.motion.scale_walk.joint_centres`).
    """

    params: BodyParameters
    body: Humanoid
    urdf: str
    marker_set: dict[str, Marker]
    measured: list[Measured]
    unmeasured: dict[str, str]
    lengths: dict[str, tuple[float, float]]
    height: tuple[float, float]
    pose: np.ndarray
    moved: dict[str, float]
    fits: dict = field(default_factory=dict)
    source: str = ""
    mode: str = "static"
    movement: float = 0.0
    joint_centres: dict[str, str] = field(default_factory=dict)

    @property
    def factors(self) -> dict[str, float]:
        """Each measurement's scale factor [-]."""
        return {m.name: m.factor for m in self.measured}

    def rms(self, fit: str = "placed") -> float:
        """The RMS marker residual over every marker and frame of a fit [m]."""
        r = self.fits[fit].residuals
        return float(np.sqrt(np.nanmean(r**2)))

    def max(self, fit: str = "placed") -> float:
        """The largest marker residual of a fit [m]."""
        return float(np.nanmax(self.fits[fit].residuals))


_COMMENT = re.compile(
    r"humanoid body: height (?P<height>[-+.\deE]+) m, mass (?P<mass>[-+.\deE]+) kg, "
    r"sex (?P<sex>\w+)(?P<lengths>(?:, \w+ [-+.\deE]+ m)*)(?P<toes>, toes)?"
    r"(?P<ranges>(?:, range \w+ [-+.\deE]+ [-+.\deE]+ deg)*)\."
)


def body_parameters_of(h):
    """The :class:`~humanoid.anthropometry.BodyParameters` a toolkit body was built from (read
    from the comment :func:`~humanoid.body.build_urdf` writes at the top of its URDF).

    Raises:
        ScalingError: the body was not built by the toolkit (an example-robot-data robot, a
            URDF of another origin).
    """
    from ..anthropometry import BodyParameters

    text = h.recipe.get("urdf", "") if isinstance(h.recipe, dict) else ""
    found = _COMMENT.search(text[:2000])
    if found is None:
        raise ScalingError(
            f"{h.source}: not one of the toolkit's bodies (humanoid build, "
            "adult_male, adult_female: their URDF says their height, mass and sex); give "
            "BodyParameters instead"
        )
    lengths = {k: float(v) for k, v in re.findall(r", (\w+) ([-+.\deE]+) m", found["lengths"])}
    pattern = r", range (\w+) ([-+.\deE]+) ([-+.\deE]+) deg"
    ranges = {k: (float(a), float(b)) for k, a, b in re.findall(pattern, found["ranges"])}
    return BodyParameters(float(found["height"]), float(found["mass"]), found["sex"], lengths,
                          toes=found["toes"] is not None, ranges=ranges)  # fmt: skip


def _unscaled(h_or_params):
    """(body, its parameters) of a body or of parameters."""
    from ..anthropometry import BodyParameters
    from ..body import build_urdf
    from ..model import load

    if isinstance(h_or_params, BodyParameters):
        return load(build_urdf(h_or_params)), h_or_params
    return h_or_params, body_parameters_of(h_or_params)


def _trial(static: MarkerTrajectories, time_range) -> MarkerTrajectories:
    if time_range is None:
        return static
    t0, t1 = time_range
    keep = (static.time >= t0 - 1e-9) & (static.time <= t1 + 1e-9)
    if not keep.any():
        raise ScalingError(
            f"{static.source or 'the static trial'}: no frame in {t0:g}-{t1:g} s (it runs "
            f"{static.time[0]:g}-{static.time[-1]:g} s)"
        )
    return MarkerTrajectories(static.time[keep], list(static.names), static.positions[keep],
                              static.source)  # fmt: skip


def _seen(static: MarkerTrajectories, names, where: str, walk: bool = False) -> list[str]:
    """The markers of ``names`` the trial has in at least one frame; warns of those missing in
    every frame, and (a static trial) of those missing in some or that moved."""
    cols = {n: static.names.index(n) for n in names if n in static.names}
    pos = static.positions
    n = len(static.time)
    never, partly, moving = [], [], []
    for name, c in cols.items():
        ok = np.all(np.isfinite(pos[:, c]), axis=1)
        if not ok.any():
            never.append(name)
            continue
        if not ok.all():
            partly.append(f"{name} ({int((~ok).sum())} of {n})")
        spread = float(np.sqrt(np.sum(np.var(pos[ok, c], axis=0))))
        if spread > STILL:
            moving.append(f"{name} ({spread * 1e3:.0f} mm)")
    if never:
        warnings.warn(f"{where}: no position in any frame for {', '.join(never)}: left out",
                      ScaleWarning, stacklevel=3)  # fmt: skip
    if partly and not walk:
        warnings.warn(f"{where}: missing in some frames (averaged over the others): "
                      + ", ".join(partly), ScaleWarning, stacklevel=3)  # fmt: skip
    if moving and not walk:
        more = f" and {len(moving) - 8} more" if len(moving) > 8 else ""
        warnings.warn(f"{where}: markers that moved in a trial meant to be still (standard "
                      f"deviation over {STILL * 1e3:.0f} mm): {', '.join(moving[:8])}{more}",
                      ScaleWarning, stacklevel=3)  # fmt: skip
    return [x for x in cols if x not in never]


def _static_pairs(static, model_pos):
    """A static trial's measure of a pair: (the mean over the frames of the two markers'
    distance, as OpenSim's ModelScaler; the standing body's distance) [m]."""

    def measure(a: str, b: str) -> tuple[float, float]:
        pa = static.positions[:, static.names.index(a)]
        pb = static.positions[:, static.names.index(b)]
        d = np.linalg.norm(pa - pb, axis=1)
        return float(np.nanmean(d)), float(np.linalg.norm(model_pos[a] - model_pos[b]))

    return measure


def _measure(seen, model_pos, measurements, where, distance):
    """(the measurements made, the unmeasured lengths with why); ``distance(a, b)`` gives a
    pair's (experimental, body) distances [m]."""
    made, unmeasured = [], {}
    cols = set(seen)
    for m in measurements:
        usable = None
        for pairs in m.alternatives:
            ok = [p for p in pairs if p[0] in cols and p[1] in cols and p[0] in model_pos
                  and p[1] in model_pos]  # fmt: skip
            if ok:
                usable = (pairs, ok)
                break
        if usable is None:
            wanted = " or ".join("/".join(f"{a}-{b}" for a, b in pairs[:2])
                                 for pairs in m.alternatives)  # fmt: skip
            why = f"no markers for the {m.name} measurement ({wanted})"
            for s in m.segments:
                unmeasured[s] = why
            if m.segments:
                warnings.warn(f"{where}: {why}: {', '.join(m.segments)} keep the stature "
                              "scaling", ScaleWarning, stacklevel=4)  # fmt: skip
            continue
        pairs, ok = usable
        if len(ok) < len(pairs):
            lost = [f"{a}-{b}" for a, b in pairs if (a, b) not in ok]
            warnings.warn(f"{where}: {m.name} measured without {', '.join(lost)} (a marker "
                          "missing from the trial or the marker set)", ScaleWarning,
                          stacklevel=4)  # fmt: skip
        rows = []
        for a, b in ok:
            experimental, model = distance(a, b)
            if model < 1e-6:
                raise ScalingError(f"{m.name}: markers {a} and {b} are at the same place on "
                                   "the body; their distance cannot scale it")  # fmt: skip
            ratio = experimental / model
            if not FACTOR_RANGE[0] <= ratio <= FACTOR_RANGE[1]:
                raise ScalingError(
                    f"{where}: {m.name}: {a}-{b} is {experimental * 1e3:.0f} mm apart, "
                    f"{model * 1e3:.0f} mm on the body (ratio {ratio:.2f}, valid "
                    f"{FACTOR_RANGE[0]}-{FACTOR_RANGE[1]}): wrong units or marker names?"
                )
            rows.append((a, b, experimental, model, ratio))
        ratios = [r[4] for r in rows]
        factor = float(np.mean(ratios))
        if max(ratios) - min(ratios) > SIDES_AGREE * factor:
            warnings.warn(f"{where}: {m.name}'s pairs disagree by more than "
                          f"{SIDES_AGREE:.0%}: " + ", ".join(f"{a}-{b} {r:.3f}"
                                                           for a, b, _, _, r in rows)
                          + " (averaged; a marker on the wrong side?)",
                          ScaleWarning, stacklevel=4)  # fmt: skip
        made.append(Measured(m.name, m.segments, rows, factor))
    return made, unmeasured


def _stature(lengths: dict, dims: dict, height: float) -> float | None:
    """The stature of the measured chain, its unmeasured elements keeping their share of the
    unscaled body's (None: nothing of the chain measured)."""
    from ..anthropometry import CHAIN

    if not any(k in lengths for k in CHAIN):
        return None
    fixed = sum(lengths[k] for k in CHAIN if k in lengths)
    share = sum(dims[k] for k in CHAIN if k not in lengths) / height
    return fixed / (1.0 - share)


def _carry(h, body, marker_set: dict, ratios: dict) -> dict[str, Marker]:
    """The markers moved onto the scaled body: each offset, in its joint's frame with the bodies
    standing, scaled along world x, y, z by its segment's ratios."""
    old, new = h.model, body.model
    d_old, d_new = old.createData(), new.createData()
    pin.forwardKinematics(old, d_old, h.standing_configuration())
    pin.forwardKinematics(new, d_new, body.standing_configuration())
    out = {}
    for name, m in marker_set.items():
        if not old.existFrame(m.frame) or not new.existFrame(m.frame):
            out[name] = m
            continue
        f_old, f_new = old.frames[old.getFrameId(m.frame)], new.frames[new.getFrameId(m.frame)]
        j_old, j_new = f_old.parentJoint, new.getJointId(old.names[f_old.parentJoint])
        R_old, R_new = d_old.oMi[j_old].rotation, d_new.oMi[j_new].rotation
        joint = old.names[j_old]
        key = joint.removeprefix("left_").removeprefix("right_")
        segment = next((s for k, s in _SEGMENT_OF.items() if key.startswith(k)), None)
        k = ratios.get(segment, ratios["stature"])
        p = R_old @ f_old.placement.act(np.asarray(m.offset, dtype=float))
        offset = f_new.placement.actInv(R_new.T @ (k * p))
        out[name] = replace(m, offset=tuple(float(x) for x in offset))
    return out


def _fit(h, static, marker_set, names, q0=None, register=False):
    """The body fitted to the trial's markers of ``names`` (the warnings of a fit kept quiet:
    the result holds what they say)."""
    from .ik import RangeLimitWarning, UnconstrainedWarning, inverse_kinematics

    used = {n: marker_set[n] for n in names}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RangeLimitWarning)
        warnings.simplefilter("ignore", UnconstrainedWarning)
        return inverse_kinematics(h, static, used, q0=q0, register=register)


def _trial_used(static, marker_set, mode, time_range, where):
    """The trial's frames and markers to scale on, its joint centres and its mode resolved."""
    if mode not in MODES:
        raise ScalingError(f"scaling mode {mode!r}: one of {', '.join(MODES)}")
    static = _trial(static, time_range)
    static, centres = joint_centres(static, marker_set)
    in_set = [n for n in static.names if n in marker_set]
    if not in_set:
        raise ScalingError(f"{where}: no marker of the trial is in the marker set (the trial's: "
                           f"{', '.join(static.names[:8])}; the set's: "
                           f"{', '.join(list(marker_set)[:8])})")  # fmt: skip
    fitted = [n for n in in_set if n not in centres]  # (a pipeline's centres measure only)
    moves = movement(static, fitted)
    if mode == "auto":
        mode = "walk" if moves > MOVING else "static"
    if mode == "walk":
        from .marker_sets import seen_frames

        span = seen_frames(static, fitted)  # (walking into the cameras' volume and out)
        static = MarkerTrajectories(static.time[span], list(static.names),
                                    static.positions[span], static.source)  # fmt: skip
    return static, centres, in_set, mode, moves


def _measured(h, static, some, marker_set, seen, fitted, measurements, walk, where):
    """The measurements made (a walk's in the unscaled body fitted to ``some`` of its frames),
    the unmeasured lengths with why, and that fit (None for a static trial)."""
    model_pos = dict(zip(seen, marker_positions(h, h.standing_configuration(), marker_set,
                                                seen)[0], strict=True))  # fmt: skip
    unscaled_fit = None
    if walk:
        unscaled_fit = _fit(h, some, marker_set, fitted, register=True)
        distance = pair_distances(h, static, marker_set, unscaled_fit.q)
    else:
        distance = _static_pairs(static, model_pos)
    made, unmeasured = _measure(seen, model_pos, measurements, where, distance)
    if not any(m.segments for m in made):
        raise ScalingError(f"{where}: no measurement can be made: "
                           + "; ".join(unmeasured.values()))  # fmt: skip
    return made, unmeasured, unscaled_fit


def _lengths(made, unmeasured: dict, dims: dict) -> dict:
    """The segments' lengths measured (those unmeasured noted in ``unmeasured``)."""
    lengths = {}
    for m in made:
        for s in m.segments:
            lengths[s] = m.factor * dims[s]
    for s in LENGTHS:
        if s not in lengths and s not in unmeasured:
            unmeasured[s] = "no measurement in the set"
    return lengths


def _height(height, lengths: dict, dims: dict, unscaled: float, where: str) -> float:
    """The subject's stature [m]: the one given (warned if off the markers'), else the markers'."""
    from_markers = _stature(lengths, dims, unscaled)
    if height is None:
        if from_markers is None:
            warnings.warn(f"{where}: nothing of the chain sole-vertex measured; the stature is "
                          f"the unscaled body's {unscaled:.3f} m (give the height)",
                          ScaleWarning, stacklevel=3)  # fmt: skip
        height = from_markers or unscaled
    elif from_markers is not None and abs(height - from_markers) > HEIGHT_AGREE * height:
        warnings.warn(f"{where}: the stature given, {height:.3f} m, is {height - from_markers:+.3f}"
                      f" m off the markers' {from_markers:.3f} m; the unmeasured "
                      + ", ".join(k for k in ("ankle_height", "head") if k not in lengths)
                      + " take up the difference", ScaleWarning, stacklevel=3)  # fmt: skip
    return height


def _built(h, height, mass, sex, lengths, toes, ranges):
    """The scaled body: its parameters, model (the unscaled one's options), URDF, dimensions;
    the unscaled body's own joint ranges kept."""
    from ..anthropometry import BodyParameters, body_dimensions
    from ..body import build_urdf

    scaled = BodyParameters(height, mass, sex, lengths, toes=toes, ranges=ranges)
    urdf = build_urdf(scaled)
    return scaled, _loaded_as(h, urdf), urdf, body_dimensions(scaled)


def _loaded_as(h, urdf: str):
    """``urdf`` loaded with the options ``h`` was loaded with (ball joints, massless links,
    locked joints)."""
    from ..model import load

    options = {k: h.recipe[k] for k in ("ball_joints", "massless", "lock") if k in h.recipe}
    return load(urdf, **options)


def with_ranges(h, ranges):
    """One of the toolkit's bodies built again with a subject's ranges of motion [deg]
    (:class:`~humanoid.anthropometry.BodyParameters`' ``ranges``) over its own, loaded as it
    was (ball joints, locked joints).

    Raises:
        ScalingError: the body was not built by the toolkit (its URDF does not say its
            parameters). BodyParameterError: an unknown joint or a range out of order.
    """
    from ..body import build_urdf

    params = body_parameters_of(h)
    params = replace(params, ranges={**params.ranges, **dict(ranges)})
    return _loaded_as(h, build_urdf(params))


def _ratios(height, params, dims, new, made) -> dict:
    """The factors (x, y, z) by which each segment's markers are carried to the scaled body."""
    # the markers carried: lengths along each segment, the stature across it
    r_h = height / params.height
    ratios = {"stature": np.full(3, r_h)}
    for s in LENGTHS:
        r = new[s] / dims[s]
        ratios[s] = np.array([r, r_h, r_h] if s == "foot" else [r_h, r_h, r])
    width = next((m.factor for m in made if m.name == "pelvis_width"), r_h)
    ratios["pelvis"] = np.array([width, width, new["pelvis"] / dims["pelvis"]])
    return ratios


def _placed(body, static, some, carried, fitted, walk, where):
    """The markers placed on the scaled body, the pose they were placed in, those free to move
    and the scaled body's fit of a walk (None for a static trial)."""
    from .ik import register_markers

    if walk:  # placed on the walk's frames fitted (see scale_walk)
        scaled_fit = _fit(body, some, carried, fitted, register=True)
        free = [n for n in fitted if not carried[n].fixed]
        placed = dict(carried) | register_markers(body, some, scaled_fit.q,
                                                  scaled_fit.marker_set, free,
                                                  scaled_fit.held)  # fmt: skip
        return placed, scaled_fit, free, scaled_fit
    # placed: the scaled body fitted to the trial's mean pose, the markers moved onto it
    cols = [static.names.index(n) for n in fitted]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # (a marker missing in some frames)
        mean = np.nanmean(static.positions[:, cols], axis=0)
    still = MarkerTrajectories(np.array([float(np.mean(static.time))]), list(fitted),
                               mean[None], where)  # fmt: skip
    pose = _fit(body, still, carried, fitted)
    free = [n for n in fitted if not carried[n].fixed]
    placed = dict(carried) | register_markers(body, still, pose.q, carried, free)
    return placed, pose, free, None


def scale_body(h_or_params, static: MarkerTrajectories, marker_set: dict[str, Marker] | None,
               mass: float, *, height: float | None = None, sex: str | None = None,
               measurements=MEASUREMENTS,
               time_range: tuple[float, float] | None = None,
               fit_frames: int | None = None, mode: str = "auto",
               ranges: Mapping[str, tuple[float, float]] | None = None) -> ScaleResult:  # fmt: skip
    """Scale a body to the subject of a static trial (see the module docstring).

    Args:
        h_or_params: The unscaled body: one of the toolkit's (its URDF says its parameters,
            :func:`body_parameters_of`) or :class:`~humanoid.anthropometry.BodyParameters`.
        static: The static trial (our axes, metres: :func:`~humanoid.motion.markers.read_trc`,
            :func:`~humanoid.motion.markers.read_c3d`).
        marker_set: Where the markers are on the unscaled body (None: its default set,
            :func:`~humanoid.motion.markers.default_markers`).
        mass: The subject's mass [kg] (10-300).
        height: The subject's stature [m] (default: the markers', see the module docstring).
        sex: ``"male"`` or ``"female"`` (default: the unscaled body's).
        measurements: The :class:`Measurement` s to make (default :data:`MEASUREMENTS`).
        time_range: (start, end) [s] of the frames to use (default: all).
        fit_frames: The residuals are those of the body fitted to this many of the trial's
            frames at most, evenly spread (default: 10 of a static trial, whose frames differ
            by their noise; 60 of a walk, on which the markers are also placed).
        mode: ``"static"``, ``"walk"`` (:mod:`~humanoid.motion.scale_walk`: the median of a
            pair's distances, pairs across a joint measured in the fitted poses, the markers
            placed on a fit of the walk's frames), or ``"auto"``: a walk if the markers move
            more than :data:`~humanoid.motion.scale_walk.MOVING` (median), else static.
        ranges: The subject's ranges of motion [deg] (``BodyParameters.ranges``: by kind or
            by joint) over the unscaled body's own (default: its own).

    Returns:
        The :class:`ScaleResult`.

    Warns:
        ScaleWarning: markers of the trial missing in every frame (left out) or some (averaged
            over the others) or moving; a measurement made without some of its pairs, or whose
            pairs disagree by more than 10 %; a segment without its markers; a given stature
            2 % off the markers'; coordinates no marker sees in the static pose.

    Raises:
        ScalingError: the body is not one of the toolkit's; an unknown ``mode``; the trial
            has no frame in ``time_range`` or no marker of the set; no measurement can be
            made; a pair's ratio outside 0.5-2 (wrong units or names). BodyParameterError:
            the mass, the stature or a measured length out of range.
    """
    from ..anthropometry import BodyParameters, body_dimensions

    h, params = _unscaled(h_or_params)
    where = static.source or "the static trial"
    # (the mass and the ranges first: nothing is worth measuring for a body not to be built)
    own = {**params.ranges, **dict(ranges or {})}
    BodyParameters(params.height, mass, sex or params.sex, ranges=own)
    marker_set = default_markers(h) if marker_set is None else dict(marker_set)
    static, centres, in_set, mode, moves = _trial_used(static, marker_set, mode, time_range, where)
    walk = mode == "walk"
    seen = _seen(static, in_set, where, walk)
    fitted = [n for n in seen if n not in centres]
    some = picked(static, fit_frames or (WALK_FRAMES if walk else 10))
    made, unmeasured, unscaled_fit = _measured(h, static, some, marker_set, seen, fitted,
                                               measurements, walk, where)  # fmt: skip
    dims = body_dimensions(params)
    lengths = _lengths(made, unmeasured, dims)
    height = _height(height, lengths, dims, params.height, where)
    scaled, body, urdf, new = _built(h, height, mass, sex or params.sex, lengths, params.toes,
                                     own)  # fmt: skip
    carried = _carry(h, body, marker_set, _ratios(height, params, dims, new, made))
    placed, pose, free, scaled_fit = _placed(body, static, some, carried, fitted, walk, where)
    if pose.unconstrained:
        warnings.warn(f"{where}: no marker sees {', '.join(pose.unconstrained)} in the "
                      f"{mode} trial's fit (held standing): the markers on them are placed as "
                      "they stand", ScaleWarning, stacklevel=2)  # fmt: skip
    moved = {n: float(np.linalg.norm(np.subtract(placed[n].offset, carried[n].offset)))
             for n in free}  # fmt: skip
    fits = {"unscaled": unscaled_fit or _fit(h, some, marker_set, fitted),
            "scaled": scaled_fit if walk else _fit(body, some, carried, fitted, pose.q[0]),
            "placed": _fit(body, some, placed, fitted, pose.q[0])}  # fmt: skip
    return ScaleResult(scaled, body, urdf, placed, made, unmeasured,
                       {s: (float(dims[s]), float(new[s])) for s in LENGTHS},
                       (params.height, float(height)), pose.q[0], moved, fits,
                       where, mode, moves, centres)  # fmt: skip
