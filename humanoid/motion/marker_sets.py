"""The shipped marker sets by name, and the one a trial's labels call for.

A lab's markers come with the names of its marker set. The toolkit ships three
(:data:`MARKER_SETS`, ``humanoid/data/markers/``), each written as landmarks placed on its
bodies by anatomy (:func:`~humanoid.motion.markers.default_markers`):

- ``gait2354``: OpenSim's gait2354 names (``R.ASIS``, ``R.Knee.Lat`` ...), the default;
- ``plugin-gait``: Vicon's Plug-in Gait, the most common clinical set (``LASI``, ``LKNE``,
  ``LTHI``, ``LANK``, ``LHEE``, ``LTOE``, ``C7``, ``CLAV``, ``LSHO``, ``LWRA`` ...);
- ``clusters``: Plug-in Gait's pelvis and trunk with thigh and shank clusters and the
  epicondyles and malleoli (``LTH1``, ``LLFC``, ``LMMAL``, ``LCAL``, ``LMT1`` ...: the labels
  of the shipped ``walking5.c3d``).

:func:`resolve_marker_set` takes a trial's markers and what the user asked for (nothing, a
set's name, a TOML file) and returns the set to fit with (:class:`ChosenSet`): without a
choice, the shipped set with the most of the trial's labels (gait2354 on a tie). Labels with a
subject's prefix (``Subject:LASI``, Vicon Nexus's when ``SUBJECTS:USES_PREFIXES`` is set) are
read without it. Labels the set does not have (a lab's extra markers, the joint centres and
virtual points a modelling pipeline writes, ``LHJC``, ``LKJC``, ``CentreOfMass`` ...) are
left out of the fit, named in a :class:`MarkerSetWarning`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MarkerSetError
from .markers import LANDMARKS, MarkerTrajectories, default_markers, landmark_names, read_markers
from .storage import read_toml

__all__ = [
    "MARKER_SETS",
    "ChosenSet",
    "MarkerSet",
    "MarkerSetWarning",
    "choose_marker_set",
    "resolve_marker_set",
    "seen_frames",
    "strip_prefix",
]

SEEN = 0.5  # a trial's frames are fitted from the first to the last with this share of its markers

_DATA = LANDMARKS.parent


class MarkerSetWarning(UserWarning):
    """A trial's labels that its marker set does not have: left out of the fit, named."""


@dataclass(frozen=True)
class MarkerSet:
    """A shipped marker set: its ``name``, its landmark ``file`` and what it is."""

    name: str
    file: Path
    description: str

    @property
    def names(self) -> tuple[str, ...]:
        """Its landmarks' marker names (the joint centres every set has left out)."""
        return tuple(landmark_names(self.file))

    @property
    def register(self) -> bool:
        """Whether inverse kinematics registers its technical markers by default (the file's
        ``register``: clusters, whose place is the lab's choice)."""
        return bool(read_toml(self.file, "landmark set").get("register", False))


MARKER_SETS = {
    "gait2354": MarkerSet("gait2354", LANDMARKS, "OpenSim gait2354's names (R.ASIS, "
                          "R.Knee.Lat, R.Heel ...), the toolkit's default"),
    "plugin-gait": MarkerSet("plugin-gait", _DATA / "plugin_gait.toml", "Vicon Plug-in Gait "
                             "(LASI, LKNE, LTHI, LANK, LHEE, LTOE, C7, CLAV, LSHO ...)"),
    "clusters": MarkerSet("clusters", _DATA / "clusters.toml", "Plug-in Gait's pelvis and "
                          "trunk, thigh and shank clusters, epicondyles and malleoli (LTH1, "
                          "LLFC, LMMAL, LCAL, LMT1 ...: walking5.c3d's labels)"),
}  # fmt: skip


@dataclass(frozen=True)
class ChosenSet:
    """The marker set a trial is fitted with (:func:`resolve_marker_set`).

    Attributes:
        name: The shipped set's name, or the file's path. markers: the set (name ->
            :class:`~humanoid.motion.markers.Marker`). trajectories: the trial's markers, their
            labels without a subject's prefix. used: the trial's labels in the set.
        ignored: the trial's labels not in it (left out, warned). register: whether to
            register its technical markers (the set's default). reason: how it was chosen.
        prefix: the subject's prefix taken off the labels ("" if none).
    """

    name: str
    markers: dict
    trajectories: MarkerTrajectories
    used: tuple[str, ...]
    ignored: tuple[str, ...]
    register: bool
    reason: str
    prefix: str = ""

    def cropped(self, fraction: float = SEEN) -> tuple[MarkerTrajectories, int, int]:
        """The trajectories from the first to the last frame in which at least ``fraction``
        of the markers in the set are seen (a subject walking into the cameras' volume and out
        of it), and how many frames were left out before and after."""
        span = seen_frames(self.trajectories, self.used, fraction)
        tr = self.trajectories
        n = len(tr.time)
        if span == slice(0, n):
            return tr, 0, 0
        return (MarkerTrajectories(tr.time[span], list(tr.names), tr.positions[span], tr.source),
                span.start, n - span.stop)  # fmt: skip

    def describe(self) -> str:
        """One line: the set, why, how many of the trial's labels it has."""
        total = len(self.used) + len(self.ignored)
        prefix = f"; labels read without their prefix {self.prefix!r}" if self.prefix else ""
        return (f"{self.name} ({self.reason}: {len(self.used)} of the trial's {total} labels"
                f"{prefix})")  # fmt: skip


def strip_prefix(names) -> tuple[list[str], str]:
    """The labels without a subject's prefix (``"Subject:LASI"`` -> ``"LASI"``), and the
    prefix (without its colon; "" if none). Labels without one are kept as they are.

    Raises:
        MarkerSetError: labels of two subjects or more (different prefixes): fit one at a time.
    """
    prefixes = sorted({str(n).rsplit(":", 1)[0] for n in names if ":" in str(n)})
    if len(prefixes) > 1:
        raise MarkerSetError(
            f"the labels are of {len(prefixes)} subjects ({', '.join(prefixes)}"
            "): inverse kinematics fits one body; keep one subject's markers"
        )
    return [str(n).rsplit(":", 1)[-1] for n in names], (prefixes[0] if prefixes else "")


def seen_frames(markers: MarkerTrajectories, names, fraction: float = SEEN) -> slice:
    """The frames from the first to the last in which at least ``fraction`` of the markers
    ``names`` are seen (all frames if none is).

    Raises:
        MarkerSetError: no frame has that many markers seen.
    """
    cols = [markers.names.index(n) for n in names if n in markers.names]
    count = np.isfinite(markers.positions[:, cols]).all(axis=2).sum(axis=1)
    ok = np.flatnonzero(count >= max(3, fraction * len(cols)))
    if not len(ok):
        raise MarkerSetError(
            f"{markers.source or 'the trial'}: no frame has {fraction:.0%} of its "
            f"{len(cols)} markers in the set seen (at most {count.max()})"
        )
    return slice(int(ok[0]), int(ok[-1]) + 1)


def choose_marker_set(names) -> tuple[str, int]:
    """The shipped set (:data:`MARKER_SETS`) with the most of these labels (prefixes taken
    off; the joint centres every set has do not count), and how many: gait2354 on a tie."""
    labels = set(strip_prefix(names)[0])
    counts = {k: len(labels & set(s.names)) for k, s in MARKER_SETS.items()}
    best = max(counts, key=lambda k: (counts[k], k == "gait2354"))
    return best, counts[best]


def _read_set(h, path: Path) -> tuple[dict, bool]:
    """A marker set's file: placed markers (``[markers.NAME]``) or landmarks."""
    spec = read_toml(path, "marker set")
    if "landmarks" in spec:
        return default_markers(h, path), bool(spec.get("register", False))
    if "markers" in spec:
        return read_markers(path), False
    raise MarkerSetError(f"{path}: a marker set has [markers.NAME] tables (placed markers, as "
                         "humanoid ik --save-markers writes) or [landmarks.NAME] tables (as "
                         "humanoid/data/markers/*.toml)")  # fmt: skip


def resolve_marker_set(h, markers: MarkerTrajectories, choice=None) -> ChosenSet:
    """The marker set to fit ``markers`` with on the body ``h`` (see the module docstring).

    Args:
        h: The body (one of the toolkit's for a shipped set). markers: The trial's markers.
        choice: None (chosen by the labels), a shipped set's name (:data:`MARKER_SETS`), a
            TOML file (placed markers or landmarks), or a set (name -> Marker).

    Raises:
        MarkerSetError: an unknown name (listing the shipped ones), a file that is not a marker
            set, labels of several subjects, no label of the trial in the set.

    Warns:
        MarkerSetWarning: naming the trial's labels the set does not have (left out).
    """
    names, prefix = strip_prefix(markers.names)
    trajectories = markers
    if prefix:
        trajectories = MarkerTrajectories(markers.time, names, markers.positions, markers.source)
    register = False
    if choice is None:
        name, count = choose_marker_set(names)
        info = MARKER_SETS[name]
        reason = "chosen by the trial's labels" if count else "the default"
        marker_set, register = default_markers(h, info.file), info.register
    elif isinstance(choice, dict):
        name, reason, marker_set = "given", "given", dict(choice)
    elif str(choice) in MARKER_SETS:
        name, reason = str(choice), "asked for"
        info = MARKER_SETS[name]
        marker_set, register = default_markers(h, info.file), info.register
    elif Path(choice).suffix.lower() == ".toml":
        name, reason = str(choice), "its file"
        marker_set, register = _read_set(h, Path(choice))
    else:
        raise MarkerSetError(f"marker set {choice!r}: one of {', '.join(MARKER_SETS)} or a TOML "
                             "file")  # fmt: skip
    used = tuple(n for n in names if n in marker_set)
    ignored = tuple(n for n in names if n not in marker_set)
    where = markers.source or "the trial"
    if not used:
        known = ", ".join(f"{k} ({', '.join(s.names[:4])} ...)" for k, s in MARKER_SETS.items())
        raise MarkerSetError(
            f"{where}: none of its labels ({', '.join(names[:8])}"
            f"{' ...' if len(names) > 8 else ''}) is in the marker set {name}; "
            f"the shipped sets: {known}; or give a TOML file (--marker-set)"
        )
    if ignored:
        centres = [n for n in ignored if n[1:] in ("HJC", "KJC", "AJC", "SJC", "EJC", "WJC")]
        why = f" ({', '.join(centres)}: a pipeline's joint centres)" if centres else ""
        warnings.warn(f"{where}: {len(ignored)} labels not in the marker set {name} left out of "
                      f"the fit: {', '.join(ignored)}{why}", MarkerSetWarning,
                      stacklevel=2)  # fmt: skip
    return ChosenSet(name, marker_set, trajectories, used, ignored, register, reason, prefix)
