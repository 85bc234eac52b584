"""A person's own walking trial as a gait lab reports it: angles, moments and powers over the
gait cycle, left and right, and the spatiotemporal table.

The trial is what a lab's pipeline writes: the coordinates of ``humanoid ik`` or OpenSim's IK
(a ``.mot``, read onto the body as ``humanoid id`` reads it:
:func:`~humanoid.motion.coordinates.configurations`), the generalised forces of ``humanoid
id`` or OpenSim's ID (a ``.sto`` of ``hip_flexion_r_moment``... [N m]), the ground's loads
(OpenSim's external loads ``.mot``, or a C3D's force plates) and a C3D's events. It is
analysed by the simulated walk's own machinery (:func:`~humanoid.walking.gait.cycle_analysis`),
so the two report the same quantities in the same conventions:

- **events**, per side, from the first source that has them: the C3D's ``EVENT`` group
  (``Left``/``Right`` ``Foot Strike``/``Foot Off``, :func:`~humanoid.motion.c3d.read_events`);
  else the foot's load: a contact while its vertical force is above :data:`THRESHOLD` (20 N)
  until it falls below :data:`RELEASE` (10 N), found on the force low-passed at
  :data:`~humanoid.walking.gait.CUTOFF` (so that noise and impact bounces do not count twice;
  contacts and gaps under 50 ms ignored), each edge then put where the unfiltered force
  crosses the thresholds (a zero-lag low-pass spreads an edge both ways: on the simulated
  walk the 15 Hz force crosses 20 N 9-16 ms before the strike and falls below 10 N 23 ms after
  the toe off); else the motion: the foot is down while one of its sole points is within 2 cm
  of the motion's floor and slower than 0.3 m/s (:func:`~humanoid.motion.inverse_dynamics.
  contact_schedule`, velocities of the coordinates low-passed at :data:`KINEMATIC_CUTOFF`).
- **cycles** from a heel strike to the next of the same foot, time-normalised to 0-100 % in
  :data:`PERCENT` (101 samples); mean and SD over each side's cycles.
- **angles** [deg]: the clinical angles of :mod:`~humanoid.walking.clinical` on the body.
- **moments** [N m/kg]: the ``.sto``'s moments turned back into the body's joint moments
  (:func:`~humanoid.motion.coordinates.generalized_forces`), then projected as
  :func:`~humanoid.walking.gait.clinical_kinetics` projects the simulation's (internal, hip
  extensor and abductor, knee extensor, ankle plantarflexor positive), divided by the
  subject's mass [kg]. A hinge's moment about axes other than its own is not in a ``.sto``:
  it is taken as the least-norm vector with the file's moment about each of the joint's axes
  (exact for the ball hip; the knee's and ankle's about their own axes).
- **powers** [W/kg]: the joint's moment times the distal segment's angular velocity relative
  to the proximal one (the sum over its coordinates of moment times rate: the hip's three,
  the knee's, the ankle's flexion and subtalar), velocities by central differences of the
  unfiltered coordinates, on the moments file's samples (the motion interpolated onto them
  if its rate differs); moments, powers and forces are low-passed at 15 Hz (zero lag) before
  the cycles are sampled, as the simulated walk's.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..model import SIDES
from ..motion.storage import MotionFileError, Table
from .clinical import arm_chains, leg_chains
from .gait import (
    CUTOFF,
    MIN_CONTACT,
    GaitAnalysis,
    ankle_joint,
    clinical_kinetics,
    contact_runs,
    cycle_analysis,
    gait_kinematics,
    hysteresis,
    low_pass,
)

__all__ = [
    "KINEMATIC_CUTOFF",
    "PERCENT",
    "RELEASE",
    "THRESHOLD",
    "Trial",
    "TrialError",
    "TrialWarning",
    "analyse_trial",
    "c3d_trial",
    "event_contacts",
    "force_contacts",
    "kinematic_contacts",
    "leg_kinetics",
    "merged_contacts",
    "read_trial",
]

THRESHOLD = 20.0  # [N] a foot's contact starts where its vertical force rises above this
RELEASE = 10.0  # [N] ... and ends where it falls below this (c3d.read_plates' hysteresis)
KINEMATIC_CUTOFF = 10.0  # [Hz] the coordinates' low-pass for the feet's speeds (events)
PERCENT = np.linspace(0.0, 100.0, 101)  # [%] the cycle's samples
SOURCES = ("C3D events", "loads", "kinematics")  # the events' sources, first found first


class TrialError(MotionFileError):
    """A trial's files cannot be reported together: a moments file without the legs' moments,
    a coordinates file given as moments (or moments as coordinates), files whose times do not
    overlap (of different trials)."""


class TrialWarning(UserWarning):
    """What a trial's report leaves out: the kinetics without a moments file, a side with
    fewer than one full cycle, events outside the motion's times, cycles whose foot was on no
    plate."""


@dataclass
class Trial:
    """A trial's report (:func:`analyse_trial`).

    Attributes:
        analysis: The :class:`~humanoid.walking.gait.GaitAnalysis` (curves over
            :data:`PERCENT`, per cycle values, ``events`` per side).
        events: per side, where its events came from (one of :data:`SOURCES`).
        kinetics: whether the moments and powers were measured (a moments file);
            forces: whether the ground's forces were (loads).
        mass: the mass the moments are divided by [kg]. source: the trial's name.
        marker_set: a C3D trial's: the set its markers were fitted with, and why
            (:meth:`~humanoid.motion.marker_sets.ChosenSet.describe`).
    """

    analysis: GaitAnalysis
    events: dict
    kinetics: bool
    forces: bool
    mass: float
    source: str = ""
    marker_set: str = ""


def force_contacts(t: np.ndarray, fz: np.ndarray, threshold: float = THRESHOLD,
                   release: float = RELEASE, cutoff: float = CUTOFF) -> list[tuple]:  # fmt: skip
    """A foot's contacts from its vertical force ``fz`` [N] at times ``t`` [s], as (strike,
    off) times (``-inf`` / ``inf`` where the record starts or ends in one): found on the force
    low-passed at ``cutoff`` [Hz] with hysteresis (above ``threshold``, until below
    ``release``), contacts and gaps under 50 ms ignored; each edge then where the unfiltered
    force crosses the thresholds within half a filter period (see the module docstring)."""
    fz = np.asarray(fz, dtype=float)
    raw = contact_runs(hysteresis(fz, threshold, release), t, 0.0)
    found = contact_runs(hysteresis(low_pass(fz, t, cutoff), threshold, release), t, MIN_CONTACT)
    reach = 0.5 / cutoff
    runs: list[tuple[int, int]] = []
    for a, b in found:
        hits = [(c, d) for c, d in raw if t[c] < t[b - 1] + reach and t[d - 1] > t[a] - reach]
        if hits:
            a, b = min(c for c, _ in hits), max(d for _, d in hits)
        if runs and a <= runs[-1][1]:  # (two found contacts reached the same raw one)
            runs[-1] = (runs[-1][0], max(b, runs[-1][1]))
        else:
            runs.append((a, b))
    return [(t[a] if a > 0 else -math.inf, t[b - 1] if b < len(t) else math.inf)
            for a, b in runs]  # fmt: skip


def kinematic_contacts(h, t: np.ndarray, q: np.ndarray, v: np.ndarray) -> dict:
    """Each foot's contacts from the motion alone (no loads), as (strike, off) times [s]:
    :func:`~humanoid.motion.inverse_dynamics.contact_schedule` (a sole point within 2 cm of the
    floor and slower than 0.3 m/s relative to it), contacts and gaps under 50 ms ignored. The
    floor is fitted to the feet's stances (:func:`~humanoid.motion.floor.fit_floor`): a
    walkway tilted 2.9 deg in the capture's frame (walking5.c3d on the unscaled body) rises
    7 cm over the walk, and on the plane of its lowest sole point one stance of five was
    found; on the fitted floor, all five. A motion without 3 still sole points (no stance) is
    judged on that plane."""
    from ..motion.floor import fit_floor
    from ..motion.inverse_dynamics import contact_schedule
    from ..motion.storage import MotionFileError

    try:
        floor = fit_floor(h, t, q)
    except MotionFileError:
        floor = None
    schedule = contact_schedule(h, t, q, v, floor=floor)
    out = {}
    for s in SIDES:
        runs = contact_runs(schedule[s][1], t, MIN_CONTACT)
        out[s] = [(t[a] if a > 0 else -math.inf, t[b - 1] if b < len(t) else math.inf)
                  for a, b in runs]  # fmt: skip
    return out


def _kind(context: str, label: str) -> tuple[str | None, str | None]:
    """(side, "strike" | "off") of a C3D event, (None, None) if it is neither."""
    side = {"l": "left", "r": "right"}.get(context.strip().lower()[:1])
    label = label.lower()
    kind = (
        "strike" if ("strike" in label or "contact" in label) else "off" if "off" in label else None
    )
    return (side, kind) if side and kind else (None, None)


def event_contacts(events, span: tuple[float, float], source: str = "") -> dict:
    """The contacts of a C3D's events (:func:`~humanoid.motion.c3d.read_events`: (time,
    context, label)) per side that has any, as (strike, off) times [s]: each foot strike to the
    next foot off (``-inf`` before a first foot off, ``inf`` after a last strike, NaN where an
    event is missing: two strikes in a row). Events outside ``span`` [s] (the motion's times)
    and events that are no foot's strike or off are left out with a :class:`TrialWarning`."""
    per: dict[str, list[tuple[float, str | None]]] = {s: [] for s in SIDES}
    outside, unknown = [], []
    for time, context, label in events:
        side, kind = _kind(context, label)
        if side is None:
            unknown.append(f"{context} {label} {time:.3f} s".strip())
        elif not span[0] - 1e-9 <= time <= span[1] + 1e-9:
            outside.append(f"{context} {label} {time:.3f} s")
        else:
            per[side].append((time, kind))
    if outside:
        warnings.warn(f"{source}: {len(outside)} events outside the motion's {span[0]:.3f}-"
                      f"{span[1]:.3f} s left out: {', '.join(outside)}", TrialWarning,
                      stacklevel=2)  # fmt: skip
    if unknown:
        warnings.warn(f"{source}: events that are no foot strike or foot off left out: "
                      f"{', '.join(unknown)}", TrialWarning, stacklevel=2)  # fmt: skip
    out = {}
    for s, seq in per.items():
        if not seq:
            continue
        contacts, on = [], None
        for i, (time, kind) in enumerate(sorted(seq)):
            if kind == "strike":
                if on is not None:
                    contacts.append((on, math.nan))  # (its foot off is missing)
                on = time
            else:
                contacts.append((on if on is not None else -math.inf if i == 0 else math.nan,
                                 time))  # fmt: skip
                on = None
        if on is not None:
            contacts.append((on, math.inf))
        out[s] = contacts
    return out


def leg_kinetics(h, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> dict:
    """Each leg's moments [N m] and powers [W] (:func:`~humanoid.walking.gait.clinical_kinetics`,
    (n, 7) per side) from the body's configurations ``q`` (n, nq), velocities ``v`` (n, nv)
    and joint moments ``tau`` (n, nv, :func:`~humanoid.motion.coordinates.generalized_forces`;
    NaN rows of the ankle's further joints count as zero): each joint group's moment (hip:
    the joints above the knee; knee; ankle: the joints from the ankle to the sole's) is the
    least-norm vector with ``tau``'s moment about each of the group's axes."""
    model = h.model
    data = model.createData()
    chains = leg_chains(h)
    legs = {}
    for s, chain in chains.items():
        ankle = ankle_joint(h, chain)
        foot = model.frames[h.sole_id(s)].parentJoint
        k, a = chain.joints.index(chain.knee), chain.joints.index(ankle)
        groups = {chain.joints[0]: chain.joints[:k], chain.knee: [chain.knee],
                  ankle: chain.joints[a : chain.joints.index(foot) + 1]}  # fmt: skip
        cols = {j: np.concatenate([np.arange(model.joints[x].idx_v,
                                             model.joints[x].idx_v + model.joints[x].nv)
                                   for x in g]) for j, g in groups.items()}  # fmt: skip
        legs[s] = (chain, ankle, foot, groups, cols)
    needed = {1} | {
        j
        for chain, _, foot, groups, _ in legs.values()
        for j in (chain.thigh, chain.knee, foot, *(g[-1] for g in groups.values()))
    }
    tau = np.where(np.isnan(tau), 0.0, tau)
    out = {s: np.zeros((len(q), 7)) for s in SIDES}
    world = pin.ReferenceFrame.WORLD
    for i in range(len(q)):
        pin.computeJointJacobians(model, data, q[i])
        # each joint's world angular axes (3, nv): its body's angular velocity is J v
        J = {j: pin.getJointJacobian(model, data, j, world)[3:] for j in needed}
        rotation = {j: data.oMi[j].rotation for j in needed}
        for s, (chain, ankle, foot, groups, cols) in legs.items():
            moment = {j: np.linalg.lstsq(J[g[-1]][:, cols[j]].T, tau[i, cols[j]], rcond=None)[0]
                      for j, g in groups.items()}  # fmt: skip
            omega = {j: J[j] @ v[i] for j in (1, chain.thigh, chain.knee, foot)}
            out[s][i] = clinical_kinetics(chain, ankle, foot, rotation.__getitem__,
                                          moment.__getitem__, omega.__getitem__)  # fmt: skip
    return out


def _foot_loads(loads, span) -> tuple[np.ndarray, dict] | None:
    """The feet's forces (times, per side (n, 3) [N]) of ``loads`` (those on ``"left"`` and
    ``"right"``) on the first foot load's times; None without any."""
    feet = [x for x in loads if x.body in SIDES]
    if not feet:
        return None
    time = feet[0].time
    force: dict[str, np.ndarray] = {}
    for x in feet:
        force[x.body] = force.get(x.body, 0.0) + x.resampled(time)[:, :3]
    if time[-1] < span[0] or time[0] > span[1]:
        raise TrialError(f"the loads ({feet[0].name or 'loads'}: {time[0]:.3f}-{time[-1]:.3f} s)"
                         f" and the motion ({span[0]:.3f}-{span[1]:.3f} s) do not overlap: "
                         "files of different trials?")  # fmt: skip
    return time, force


def merged_contacts(loaded: list[tuple], moving: list[tuple]) -> tuple[list[tuple], int]:
    """A foot's contacts from its loads (``loaded``: (strike, off) times [s]), with the
    motion's (``moving``: :func:`kinematic_contacts`) where no load overlaps them (a lab's
    plates catch a step or two of a walk), and how many of the motion's were added. A load's
    edges are the precise ones: where it overlaps a motion's contact it replaces it, and the
    motion's added strikes and offs are moved by the mean difference between the two where
    both saw a contact (on walking5.c3d the motion's strikes came 38 ms before the left
    plate's and 31 ms after the right's: a stride from a plate's strike to the motion's next
    is otherwise that much off)."""
    pairs = [(a - c, b - d) for a, b in loaded for c, d in moving if a <= d and c <= b]
    shift = [np.mean([p[k] for p in pairs if math.isfinite(p[k])] or [0.0]) for k in (0, 1)]
    out = list(loaded)
    for on, off in moving:
        if not any(a <= off and on <= b for a, b in loaded):
            out.append((on + shift[0], off + shift[1]))
    out.sort(key=lambda c: c[0])  # (-inf first: the record starts in it)
    return out, len(out) - len(loaded)


def _within(contacts: list[tuple], span: tuple[float, float]) -> list[tuple]:
    """The contacts seen in the motion's ``span`` [s]: those outside it left out, an edge
    beyond it unknown (``-inf``, ``inf``)."""
    out = []
    for on, off in contacts:
        if off < span[0] or on > span[1]:
            continue
        out.append((on if on >= span[0] else -math.inf, off if off <= span[1] else math.inf))
    return out


def _moments_on(moments: Table, time: np.ndarray) -> Table:
    """The moments table at ``time`` (those of the motion's times its own times cover)."""
    if moments.time[-1] < time[0] or moments.time[0] > time[-1]:
        raise TrialError(
            f"{moments.source}: its times ({moments.time[0]:.3f}-{moments.time[-1]:.3f} s) and "
            f"the motion's ({time[0]:.3f}-{time[-1]:.3f} s) do not overlap: files of different "
            "trials?"
        )
    tol = 1e-6 * max(1.0, abs(time[-1]))
    inside = time[(time >= moments.time[0] - tol) & (time <= moments.time[-1] + tol)]
    data = np.column_stack([np.interp(inside, moments.time, moments.data[:, i])
                            for i in range(len(moments.labels))])  # fmt: skip
    return Table(inside, list(moments.labels), data, False, moments.name, source=moments.source)


def _check_moments(h, moments: Table, cmap) -> None:
    """The legs' moment columns of ``cmap`` that the table must have (TrialError naming the
    file and the first missing ones); a missing subtalar moment warns (taken as zero)."""
    model = h.model
    if not any(x.endswith(("_moment", "_force")) for x in moments.labels):
        raise TrialError(
            f"{moments.source}: no generalised forces (columns like hip_flexion_r_moment): "
            "not a moments file (.sto of inverse dynamics)"
        )
    chains = leg_chains(h)
    needed, optional = [], []
    for chain in chains.values():
        ankle = ankle_joint(h, chain)
        joints = {model.names[j] for j in (chain.joints[0], chain.knee, ankle)}
        for jm in cmap.joints:
            if jm.joints[0] in joints:
                needed += [f"{c}_moment" for c in jm.columns]
            elif jm.joints[0] in {model.names[j] for j in chain.joints}:
                optional += [f"{c}_moment" for c in jm.columns]
    missing = [x for x in needed if x not in moments]
    if missing:
        more = " ..." if len(moments.labels) > 12 else ""
        raise TrialError(
            f"{moments.source}: no column {', '.join(missing[:4])}"
            f"{' ...' if len(missing) > 4 else ''} (the {cmap.name} map's leg moments, N m); "
            f"its columns: {', '.join(moments.labels[:12])}{more}"
        )
    absent = [x for x in optional if x not in moments]
    if absent:
        warnings.warn(f"{moments.source}: no {', '.join(absent)}: taken as zero (the ankle's "
                      "power is its flexion's only)", TrialWarning, stacklevel=3)  # fmt: skip


def analyse_trial(h, time, q, moments: Table | None = None, loads=(), events=(), *,
                  mass: float | None = None, cmap="rajagopal", speed: float | None = None,
                  threshold: float = THRESHOLD, release: float = RELEASE,
                  source: str = "") -> Trial:  # fmt: skip
    """A trial's gait analysis (see the module docstring).

    Args:
        h: The body the motion is on (its clinical angles, feet and leg length).
        time: (n,) [s]. q: (n, nq) the body's configurations (a ``.mot`` read by
            :func:`~humanoid.motion.coordinates.configurations`).
        moments: The generalised forces (a ``.sto`` read by
            :func:`~humanoid.motion.storage.read_storage`, OpenSim's names, N m), or None:
            kinematics only. loads: :class:`~humanoid.motion.loads.Load` s (the feet's, world
            axes). events: a C3D's events (:func:`~humanoid.motion.c3d.read_events`).
        mass: [kg] the subject's, the moments are divided by (default the body's).
        cmap: The moments' coordinate map (a name of
            :data:`~humanoid.motion.coordinates.MAPS` or a map). speed: [m/s] for the
            normative bands (a treadmill's belt; default the strides'). threshold, release:
            [N] the loads' contact hysteresis. source: the trial's name (in messages).

    Raises:
        TrialError: a moments file without the legs' moments or one that is not a moments
            file, moments or loads whose times do not overlap the motion's.
        HumanoidError: q of the wrong shape, fewer than 3 samples, time not increasing.

    Warns:
        TrialWarning: naming what was left out (see :class:`TrialWarning`).
    """
    from ..motion.coordinates import MAPS
    from ..motion.inverse_dynamics import derivatives

    model = h.model
    cmap = MAPS[cmap] if isinstance(cmap, str) else cmap
    mass = float(h.mass if mass is None else mass)
    if not (math.isfinite(mass) and mass > 0.0):
        raise TrialError(f"{source}: the subject's mass must be positive [kg], got {mass}")
    tu, qu, vu, _ = derivatives(model, time, q, cutoff=None)
    span = (float(tu[0]), float(tu[-1]))
    if moments is not None:
        _check_moments(h, moments, cmap)
    force = _foot_loads(loads, span)
    contacts, where = _trial_contacts(h, tu, qu, span, events, force, threshold, release,
                                      source)  # fmt: skip
    te = force[0] if force is not None and set(where.values()) == {SOURCES[1]} else tu
    # the kinematics, on the motion's samples
    strikes = [on for on, _ in contacts["right"] if np.isfinite(on)]
    stride = float(np.median(np.diff(strikes))) if len(strikes) > 1 else 1.0
    chains = leg_chains(h)
    arms = arm_chains(h, chains)
    kinematics = gait_kinematics(h, tu, qu, stride, chains, arms)
    kinetics = None
    if moments is not None:  # on the moments' own samples, the motion interpolated onto them
        kinetics = _trial_kinetics(h, time, q, (tu, qu, vu), moments, cmap)
    else:
        warnings.warn(f"{source}: no moments: kinematics only (no moments or powers)",
                      TrialWarning, stacklevel=2)  # fmt: skip
    if force is not None:
        force = (force[0], {s: low_pass(f, force[0]) for s, f in force[1].items()})
    analysis = cycle_analysis(h, contacts, te, tu, kinematics, mass=mass, force=force,
                              kinetics=kinetics, window=span, arms=bool(arms), percent=PERCENT,
                              speed=speed, require_load=force is not None,
                              source=source)  # fmt: skip
    _warn_missing(analysis, where, kinetics, force, source)
    return Trial(analysis, where, kinetics is not None, force is not None, mass, source)


def _trial_contacts(h, tu, qu, span: tuple, events, force, threshold: float, release: float,
                    source: str) -> tuple[dict, dict]:  # fmt: skip
    """Each side's contacts (foot strike, foot off) [s] and where they came from: the C3D's
    events, else the plates' loads (the motion's own contacts between the plates' steps), else
    the motion (a sole point low and still), with a :class:`TrialWarning`."""
    from ..motion.inverse_dynamics import derivatives

    model = h.model
    rate = 1.0 / float(tu[1] - tu[0])
    # the events, per side from the first source that has them
    contacts, where = {}, {}
    if len(events):
        for s, c in event_contacts(events, span, source).items():
            contacts[s], where[s] = c, SOURCES[0]
    moved = None  # the motion's own contacts, found once if needed

    def motion_contacts():
        nonlocal moved
        if moved is None:
            cutoff = min(KINEMATIC_CUTOFF, 0.4 * rate)
            _, qk, vk, _ = derivatives(model, tu, qu, cutoff=cutoff)
            moved = kinematic_contacts(h, tu, qk, vk)
        return moved

    if force is not None:
        for s in SIDES:
            if s not in contacts and s in force[1]:
                found = force_contacts(force[0], force[1][s][:, 2], threshold, release)
                # (plates catch some steps only: the motion's contacts between them)
                contacts[s], added = merged_contacts(_within(found, span),
                                                     motion_contacts()[s])  # fmt: skip
                where[s] = SOURCES[1] if not added else f"{SOURCES[1]} ({added} from kinematics)"
    if len(contacts) < 2:
        for s, c in motion_contacts().items():
            if s not in contacts:
                contacts[s], where[s] = c, SOURCES[2]
                warnings.warn(f"{source}: no {s} foot events or loads: its events from its "
                              "motion (a sole point low and still)", TrialWarning,
                              stacklevel=3)  # fmt: skip
    return contacts, where


def _trial_kinetics(h, time, q, motion: tuple, moments: Table, cmap) -> tuple:
    """The legs' kinetics (times, per side (n, 7) moments [N m] and powers [W], low-passed) on
    the moments' own samples, the motion (``motion``: (t, q, v) on its samples, from ``time``
    and ``q``) interpolated onto them."""
    from ..motion.coordinates import generalized_forces
    from ..motion.inverse_dynamics import derivatives

    model = h.model
    tu, qu, vu = motion
    rate = 1.0 / float(tu[1] - tu[0])
    tm, qm, vm = tu, qu, vu
    if len(moments.time) > 1 and not math.isclose(moments.rate, rate, rel_tol=1e-6):
        tm, qm, vm, _ = derivatives(model, time, q, cutoff=None, rate=moments.rate)
    on = _moments_on(moments, tm)
    inside = np.isin(tm, on.time)
    tau = generalized_forces(h, qm[inside], on, cmap)
    kin = leg_kinetics(h, qm[inside], vm[inside], tau)
    return (on.time, {s: low_pass(k, on.time) for s, k in kin.items()})


def _warn_missing(analysis, where: dict, kinetics, force, source: str) -> None:
    """A :class:`TrialWarning` for a side without a full cycle, and for cycles without the
    moments and powers or ground forces that the trial has."""
    for s in SIDES:
        n = len(analysis.cycles[s])
        if n == 0:
            listed = ", ".join(f"{x:.3f}" for x in analysis.events[s]["strike"]) or "none"
            warnings.warn(f"{source}: the {s} side has fewer than one full cycle (heel strikes "
                          f"at {listed} s, from {where.get(s, 'no source')}): nothing of it "
                          "is drawn or tabled", TrialWarning, stacklevel=3)  # fmt: skip
            continue
        for what, names, present in (("moments and powers", "hip_power", kinetics),
                                     ("ground forces", "grf_vertical", force)):  # fmt: skip
            k = len(analysis.curves[s][names])
            if present is not None and k < n:
                warnings.warn(f"{source}: {n - k} of the {s} side's {n} cycles without "
                              f"{what} (the foot on no plate, or outside the file's times)",
                              TrialWarning, stacklevel=3)  # fmt: skip


def read_trial(h, motion, moments=None, loads=None, events=None, *, cmap=None,
               mass: float | None = None, speed: float | None = None, sides=None,
               xml=None, floor: bool = True, threshold: float = THRESHOLD) -> Trial:  # fmt: skip
    """:func:`analyse_trial` of a trial's files.

    Args:
        h: The body. motion: the coordinates (``.mot``/``.sto``, OpenSim's gait models' names:
            ``humanoid ik``'s). moments: ``humanoid id``'s or OpenSim ID's ``.sto``.
        loads: OpenSim's external loads ``.mot`` (``sides``: {prefix: side}, ``xml``: its
            ExternalLoads file) or a C3D (its force plates, given to the feet by its markers).
        events: a C3D whose ``EVENT`` group has the foot strikes and offs.
        cmap: The coordinates' map (default told from the file). floor: put the motion's
            stances on the floor (as ``humanoid id``). threshold: [N] a foot's
            contact in the loads (it ends below half of it). mass, speed: see
            :func:`analyse_trial`.

    Raises:
        MotionFileError: a file missing or unreadable, a ``.mot`` without a ``time`` column
            (naming the file and line). TrialError: see :func:`analyse_trial`; a moments file
            given as the motion.
    """
    from ..motion.coordinates import MAPS, UnmappedWarning, configurations, guess_map
    from ..motion.storage import read_storage

    table = read_storage(motion)
    if any(x.endswith("_moment") for x in table.labels):
        raise TrialError(f"{motion}: its columns are generalised forces (…_moment): a moments "
                         "file, not the motion's coordinates")  # fmt: skip
    cmap = MAPS[cmap] if isinstance(cmap, str) else cmap or guess_map(table)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnmappedWarning)  # (columns of arms and toes)
        time, q, _ = configurations(h, table, cmap, floor=floor)
    forces = read_storage(moments) if moments is not None else None
    found = []
    if loads is not None:
        if Path(loads).suffix.lower() == ".c3d":
            from ..motion.c3d import c3d_loads

            found = c3d_loads(loads)[1]
        else:
            from ..motion.loads import read_loads

            found = read_loads(loads, sides, xml)
    marks = []
    if events is not None:
        from ..motion.c3d import read_events

        if Path(events).suffix.lower() != ".c3d":
            raise TrialError(f"{events}: events are read from a C3D file's EVENT group")
        marks = read_events(events)
    return analyse_trial(h, time, q, forces, found, marks, mass=mass, cmap=cmap, speed=speed,
                         threshold=threshold, release=0.5 * threshold,
                         source=Path(motion).name)  # fmt: skip


def c3d_trial(h, path, *, mass: float | None = None, speed: float | None = None,
              marker_set=None) -> Trial:  # fmt: skip
    """:func:`analyse_trial` of a C3D trial with markers (and force plates): inverse
    kinematics of its markers on the body (:func:`~humanoid.motion.ik.inverse_kinematics`,
    with ``marker_set``: a shipped set's name, a TOML file, or None: the shipped set its
    labels call for, :func:`~humanoid.motion.marker_sets.resolve_marker_set`, which warns of
    the labels it leaves out; the frames where half the markers are seen; technical markers
    registered if the set says so), its plates' loads given to the feet by its markers,
    inverse dynamics (:func:`~humanoid.motion.inverse_dynamics.inverse_dynamics`, 6 Hz, as
    ``humanoid id``) with them (without plates: kinematics only), its events."""
    from ..motion.c3d import c3d_loads, read_events
    from ..motion.coordinates import generalized_forces_table
    from ..motion.ik import inverse_kinematics
    from ..motion.inverse_dynamics import inverse_dynamics
    from ..motion.marker_sets import resolve_marker_set
    from ..motion.markers import read_c3d

    chosen = resolve_marker_set(h, read_c3d(path), marker_set)
    markers = chosen.cropped()[0]
    fit = inverse_kinematics(h, markers, chosen.markers, register=chosen.register)
    try:
        loads = c3d_loads(path)[1]
    except MotionFileError as exc:  # no force plates
        warnings.warn(f"{exc}: no inverse dynamics", TrialWarning, stacklevel=2)
        loads = []
    moments = None
    if loads:
        r = inverse_dynamics(h, fit.time, fit.q, loads)
        moments = generalized_forces_table(h, r.time, r.q, r.tau, "rajagopal")
        moments.source = str(path)
    trial = analyse_trial(h, fit.time, fit.q, moments, loads, read_events(path), mass=mass,
                          speed=speed, source=Path(path).name)  # fmt: skip
    return replace(trial, marker_set=chosen.describe())
