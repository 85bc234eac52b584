"""Scaling from a walking trial: what differs from a static one (:func:`~humanoid.motion.scale.
scale_body` with ``mode="walk"``, chosen by itself when the markers move).

Many labs, and most public datasets, have no static trial. A walk still holds what scaling
needs, measured another way:

- **Is it a walk?** The median over the markers of how far each moves (the square root of its
  position's summed variances over the frames it is seen in): over :data:`MOVING` (5 cm) it is
  not a static trial. A subject standing sways a few millimetres; a walk moves metres.
- **The frames** are those from the first to the last in which half the set's markers are
  seen (:func:`~humanoid.motion.marker_sets.seen_frames`: a subject walking into the cameras'
  volume and out of it).
- **A pair's experimental distance** is the median over the frames in which both its markers
  are seen, not the mean: two markers on one segment keep their distance, so the median is
  that distance and a frame of a marker mislabelled or reconstructed astray does not move it.
- **A pair's distance on the body**: two markers on one rigid body keep the standing body's
  distance. A pair across a joint (an anterior superior iliac spine and a femoral epicondyle:
  the hip between them) changes with the pose: its body distance is the median over the
  unscaled body fitted to the walk's frames (:func:`~humanoid.motion.ik.inverse_kinematics`,
  its technical markers registered), the pose the experimental distances were measured in.
- **Joint centres** that a pipeline computed and wrote into the trial (Nexus's ``LHJC``,
  ``RKJC``, ``LAJC`` ...: :data:`JOINT_CENTRE`, a side letter and HJC, KJC, AJC, SJC, EJC or
  WJC, after a subject's prefix) are read as the set's joint centres (``left_hip``,
  ``right_knee`` ...) when the set has those: the first alternative of the thigh's and shank's
  :data:`~humanoid.motion.scale.MEASUREMENTS`, which span the segments exactly. They measure,
  they are not fitted (the pipeline computed them from the very markers the fit uses).
- **The mass** from a C3D's force plates (:func:`plate_mass`), if the file does not say it:
  over each single stance on a plate (the other foot swinging: its markers faster than 1 m/s,
  no other plate loaded; the stance foot's markers all over the plate, else part of the load
  goes to the floor beside it: walking5's left heel lands 13 cm off FP1, which reads 48 kg),
  its unloaded reading taken off (the median outside contact: walking5's read -15 N), the
  vertical impulse is the mass times g T plus the change of the
  mass centre's vertical speed, read from the pelvis markers' (the mass centre rises through
  single stance and falls: the mean force alone reads some 5-10 % light).
- **Placing the markers** (OpenSim's MarkerPlacer on a static trial): the scaled body, its
  markers carried, is fitted to the walk's frames (the technical markers registered first,
  as :func:`~humanoid.motion.ik.inverse_kinematics` does), and every marker not ``fixed`` is
  moved to its mean place on its segment over that fit (:func:`~humanoid.motion.ik.
  register_markers`: frames in which it is missing, or its segment unseen, do not count).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..errors import ScalingError
from .markers import Marker, MarkerTrajectories, marker_positions

__all__ = [
    "JOINT_CENTRE",
    "MOVING",
    "Weighed",
    "joint_centres",
    "movement",
    "pair_distances",
    "picked",
    "plate_mass",
]

MOVING = 0.05  # [m]: a trial whose markers move more than this (median) is not static
# a pipeline's joint centre: side, joint (Nexus: LHJC, RKJC, LAJC ...; a prefix taken off)
JOINT_CENTRE = re.compile(r"^(?P<side>[LR])(?P<joint>HJC|KJC|AJC|SJC|EJC|WJC)$")
_JOINT_OF = {"HJC": "hip", "KJC": "knee", "AJC": "ankle", "SJC": "shoulder", "EJC": "elbow",
             "WJC": "wrist"}  # fmt: skip


def joint_centres(trial: MarkerTrajectories, marker_set: dict[str, Marker]):
    """The trial with its pipeline's joint centres named as the set's (``LHJC`` ->
    ``left_hip``), and which were renamed ({the set's name: the trial's label}). A label whose
    set name the trial already has, or that the set does not have, is left as it is."""
    renamed, names = {}, list(trial.names)
    for k, label in enumerate(trial.names):
        found = JOINT_CENTRE.match(str(label).rsplit(":", 1)[-1])
        if found is None:
            continue
        side = "left" if found["side"] == "L" else "right"
        name = f"{side}_{_JOINT_OF[found['joint']]}"
        if name in marker_set and name not in trial.names and name not in renamed:
            names[k] = name
            renamed[name] = str(label)
    if not renamed:
        return trial, {}
    return MarkerTrajectories(trial.time, names, trial.positions, trial.source), renamed


def movement(trial: MarkerTrajectories, names) -> float:
    """The median over the markers ``names`` of how far each moves [m]: the square root of its
    position's summed variances over the frames in which it is seen."""
    spread = []
    for n in names:
        p = trial.positions[:, trial.names.index(n)]
        ok = np.all(np.isfinite(p), axis=1)
        if ok.sum() > 1:
            spread.append(float(np.sqrt(np.sum(np.var(p[ok], axis=0)))))
    return float(np.median(spread)) if spread else 0.0


def picked(trial: MarkerTrajectories, count: int) -> MarkerTrajectories:
    """``count`` of the trial's frames at most, evenly spread from its first to its last."""
    pick = np.unique(np.linspace(0, len(trial.time) - 1, max(count, 1)).round().astype(int))
    return MarkerTrajectories(trial.time[pick], list(trial.names), trial.positions[pick],
                              trial.source)  # fmt: skip


def _rigid(model, marker_set, a: str, b: str) -> bool:
    """Whether two markers are on one body (their frames' parent joint is the same)."""
    ja = model.frames[model.getFrameId(marker_set[a].frame)].parentJoint
    jb = model.frames[model.getFrameId(marker_set[b].frame)].parentJoint
    return ja == jb


def pair_distances(h, trial: MarkerTrajectories, marker_set: dict[str, Marker],
                   fitted: np.ndarray):  # fmt: skip
    """The walk's measure of a pair (see the module docstring): a function of two marker
    names giving (the experimental distance, the body's) [m]. ``fitted`` (k, nq): the unscaled
    body ``h`` fitted to k of the trial's frames, the poses a pair across a joint is measured
    in on the body."""
    model = h.model
    standing = h.standing_configuration()

    def measure(a: str, b: str) -> tuple[float, float]:
        pa = trial.positions[:, trial.names.index(a)]
        pb = trial.positions[:, trial.names.index(b)]
        d = np.linalg.norm(pa - pb, axis=1)
        experimental = float(np.nanmedian(d))  # (every frame both are seen in)
        poses = [standing] if _rigid(model, marker_set, a, b) else list(fitted)
        on_body = [np.linalg.norm(np.subtract(*marker_positions(h, q, marker_set, [a, b])[0]))
                   for q in poses]  # fmt: skip
        return experimental, float(np.median(on_body))

    return measure


SWING = 1.0  # [m/s]: a foot whose markers move faster than this (mean) is swinging
G = 9.81  # [m/s^2]


@dataclass(frozen=True)
class Weighed:
    """The subject weighed on the plates (:func:`plate_mass`): the ``mass`` [kg], the mean of
    each single stance's; ``stances``: (plate, start [s], end [s], its mass [kg]) each."""

    mass: float
    stances: tuple[tuple[str, float, float, float], ...]


def _mean_seen(values: np.ndarray) -> np.ndarray:
    """Each row's mean over its finite values; NaN, without numpy's warning, where none is."""
    out = np.full(len(values), np.nan)
    ok = np.isfinite(values).any(axis=1)
    out[ok] = np.nanmean(values[ok], axis=1)
    return out


def _speed(markers: MarkerTrajectories, cols) -> np.ndarray:
    """The mean speed of the markers ``cols`` per frame [m/s] (NaN where none is seen)."""
    v = np.gradient(markers.positions[:, cols], markers.time, axis=0)
    with np.errstate(invalid="ignore"):
        s = np.linalg.norm(v, axis=2)
    return _mean_seen(s)


def _vertical_speed(markers: MarkerTrajectories, cols, t: float, half: float = 0.02) -> float:
    """The markers' ``cols`` mean height's rate at ``t`` [m/s]: a line fitted over ``t +-
    half``."""
    z = _mean_seen(markers.positions[:, cols, 2])
    near = (np.abs(markers.time - t) <= half) & np.isfinite(z)
    if near.sum() < 3:
        raise ScalingError(f"{markers.source}: the pelvis markers are not seen at {t:.3f} s")
    return float(np.polyfit(markers.time[near], z[near], 1)[0])


def _on_plate(p, markers: MarkerTrajectories, cols, t: np.ndarray) -> bool:
    """Whether every foot marker ``cols`` is over the plate's surface (its corners' box in x
    and y) in the middle third of the contact ``t``."""
    mid = (markers.time >= t[0] + (t[-1] - t[0]) / 3) & (markers.time <= t[-1] - (t[-1] - t[0]) / 3)
    xy = markers.positions[mid][:, cols, :2].reshape(-1, 2)
    xy = xy[np.isfinite(xy).all(axis=1)]
    lo, hi = p.corners[:, :2].min(axis=0), p.corners[:, :2].max(axis=0)
    return bool(len(xy)) and bool(np.all((xy >= lo) & (xy <= hi)))


def plate_mass(plates, markers: MarkerTrajectories, pelvis, swing: float = SWING,
               shortest: float = 0.1) -> Weighed:  # fmt: skip
    """The subject's mass from the force plates (see the module docstring).

    Args:
        plates: :func:`~humanoid.motion.c3d.read_plates`. markers: the trial's markers (their
            foot markers tell the feet apart, :func:`~humanoid.motion.c3d.foot_markers`).
        pelvis: The pelvis markers' names (their mean height's rate stands for the mass
            centre's). swing: A foot faster than this is swinging [m/s]. shortest: A single
            stance shorter than this is not used [s].

    Raises:
        ScalingError: no single stance of at least ``shortest`` with the foot all on a plate,
            no pelvis marker.
    """
    from .c3d import assign_contacts, foot_markers

    cols = [markers.names.index(n) for n in pelvis if n in markers.names]
    if not cols:
        raise ScalingError(f"{markers.source}: weighing on the plates needs pelvis markers")
    feet = foot_markers(markers.names)
    speed = {s: _speed(markers, c) for s, c in feet.items() if c}
    rows = []
    for p, i0, i1, side in assign_contacts(plates, markers):
        other = "right" if side == "left" else "left"
        if side is None or other not in speed:
            continue
        t = p.time[i0:i1]
        swinging = np.interp(t, markers.time, speed[other], left=np.nan, right=np.nan) > swing
        for q in plates:
            if q is not p:
                swinging &= ~np.interp(t, q.time, q.contact.astype(float)).astype(bool)
        if not _on_plate(p, markers, feet[side], t):
            continue
        edges = np.flatnonzero(np.diff(np.concatenate([[0], swinging.astype(np.int8), [0]])))
        if not len(edges):
            continue
        a, b = max(zip(edges[::2], edges[1::2], strict=True), key=lambda e: e[1] - e[0])
        if t[b - 1] - t[a] < shortest:
            continue
        sl = slice(i0 + a, i0 + b)
        unloaded = float(np.median(p.force[~p.contact, 2])) if (~p.contact).any() else 0.0
        impulse = float(np.trapezoid(p.force[sl, 2] - unloaded, p.time[sl]))
        t0, t1 = float(p.time[sl][0]), float(p.time[sl][-1])
        dv = _vertical_speed(markers, cols, t1) - _vertical_speed(markers, cols, t0)
        rows.append((p.name, t0, t1, impulse / (G * (t1 - t0) + dv)))
    if not rows:
        raise ScalingError(f"{markers.source}: no single stance of {shortest:g} s with the foot "
                           "all on a plate (the other foot swinging, no other plate loaded): "
                           "give the mass")  # fmt: skip
    return Weighed(float(np.mean([r[3] for r in rows])), tuple(rows))
