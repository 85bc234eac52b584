"""Body segment parameters: de Leva (1996) Table 4, scaled by a person's height and mass.

Sources (the numbers below are copied with their source named next to them):

- **de Leva 1996**: P. de Leva, "Adjustments to Zatsiorsky-Seluyanov's segment inertia
  parameters", J. Biomech. 29(9):1223-1230, Table 4 (mass fraction, CoM position from the
  segment origin as a fraction of length, radii of gyration about the sagittal, transverse and
  longitudinal axes as fractions of length) and the reference subjects' segment lengths [mm].
  Cross-checked in three public copies: BMClab/BMC ``data/BSP*_ZdeLeva.txt``, R. Gurchiek's
  ``deleva.m`` and pyomeca/biobuddy ``characteristics/de_leva.py``.
- **Winter 2009**: D. A. Winter, *Biomechanics and Motor Control of Human Movement*, Fig. 4.1
  (after Drillis & Contini 1966): ankle height, foot width, shoulder and hip widths as fractions
  of stature.
- **Dumas 2007 / ERD**: hip and shoulder joint-centre offsets as fractions of stature, as used by
  example-robot-data's ``HumanLoader`` (after Dumas, Cheze & Verriest 2007).

Axis convention of the radii (de Leva's columns, as read by Gurchiek and biobuddy): ``r_sag``
is about the antero-posterior axis (x, forward), ``r_trans`` about the medio-lateral axis
(y, left), ``r_long`` about the segment's long axis (z for upright segments). The foot's long
axis is horizontal: its ``r_long`` goes on x (forward), ``r_sag`` on y (lateral) and
``r_trans`` on z (vertical), Gurchiek's mapping.

Closure rule (de Leva's lengths do not add up to stature: the male chain is 2.0 % long, the
female one 0.1 % short): the vertical chain sole -> ankle -> knee -> hip -> navel -> xiphoid ->
C7 -> vertex is ankle height + shank + thigh + lower, middle and upper trunk + head. Every
element of this chain that the caller did not measure is multiplied by one common factor so that
the chain equals the stature exactly. Arms, hands and feet are scaled by stature only.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from .errors import BodyParameterError

__all__ = [
    "CHAIN",
    "DE_LEVA_1996",
    "JOINT_RANGES",
    "REFERENCE_SUBJECT",
    "SIDES",
    "STATURE_FRACTIONS",
    "BodyParameters",
    "JointRange",
    "Segment",
    "SegmentRow",
    "FootParts",
    "body_dimensions",
    "range_names",
    "ranges_text",
    "segments",
    "split_foot",
]

HEIGHT_RANGE = (0.5, 2.5)  # [m]
MASS_RANGE = (10.0, 300.0)  # [kg]
SEXES = ("male", "female")


@dataclass(frozen=True)
class SegmentRow:
    """One row of de Leva (1996) Table 4.

    Attributes:
        origin: Proximal landmark (the CoM fraction is measured from it).
        end: Distal landmark.
        length_mm: Mean segment length of the reference subject [mm].
        mass: Fraction of total body mass [-].
        com: CoM position from ``origin`` as a fraction of the length [-].
        r_sag: Radius of gyration about the antero-posterior axis, fraction of length [-].
        r_trans: Radius of gyration about the medio-lateral axis, fraction of length [-].
        r_long: Radius of gyration about the longitudinal axis, fraction of length [-].
    """

    origin: str
    end: str
    length_mm: float
    mass: float
    com: float
    r_sag: float
    r_trans: float
    r_long: float


# Reference subjects of de Leva (1996): stature [m], mass [kg] (Gurchiek deleva.m).
REFERENCE_SUBJECT = MappingProxyType({"male": (1.741, 73.0), "female": (1.735, 61.9)})

# de Leva (1996) Table 4, the rows this body uses. Keys are our segment names.
# head: "Head 2" VERT->CERV (head with neck); thorax: "Upper trunk 2" CERV->XYPH;
# abdomen: "Mid trunk" XYPH->OMPH; pelvis: "Lower trunk" OMPH->MIDH; shank: "Shank 2" KJC->AJC
# (ends at the ankle joint centre, where our ankle joint is). Others: the main rows.
# fmt: off
DE_LEVA_1996: Mapping[str, Mapping[str, SegmentRow]] = MappingProxyType({
    "male": MappingProxyType({
        #                     origin   end     L[mm]  mass    CoM     r_sag  r_trans r_long
        "head":      SegmentRow("VERT", "CERV", 242.9, 0.0694, 0.5002, 0.303, 0.315, 0.261),
        "thorax":    SegmentRow("CERV", "XYPH", 242.1, 0.1596, 0.5066, 0.505, 0.320, 0.465),
        "abdomen":   SegmentRow("XYPH", "OMPH", 215.5, 0.1633, 0.4502, 0.482, 0.383, 0.468),
        "pelvis":    SegmentRow("OMPH", "MIDH", 145.7, 0.1117, 0.6115, 0.615, 0.551, 0.587),
        "upper_arm": SegmentRow("SJC", "EJC", 281.7, 0.0271, 0.5772, 0.285, 0.269, 0.158),
        "forearm":   SegmentRow("EJC", "WJC", 268.9, 0.0162, 0.4574, 0.276, 0.265, 0.121),
        "hand":      SegmentRow("WJC", "MET3", 86.2, 0.0061, 0.7900, 0.628, 0.513, 0.401),
        "thigh":     SegmentRow("HJC", "KJC", 422.2, 0.1416, 0.4095, 0.329, 0.329, 0.149),
        "shank":     SegmentRow("KJC", "AJC", 440.3, 0.0433, 0.4395, 0.251, 0.246, 0.102),
        "foot":      SegmentRow("HEEL", "TTIP", 258.1, 0.0137, 0.4415, 0.257, 0.245, 0.124),
    }),
    "female": MappingProxyType({
        "head":      SegmentRow("VERT", "CERV", 243.7, 0.0668, 0.4841, 0.271, 0.295, 0.261),
        "thorax":    SegmentRow("CERV", "XYPH", 228.0, 0.1545, 0.5050, 0.466, 0.314, 0.449),
        "abdomen":   SegmentRow("XYPH", "OMPH", 205.3, 0.1465, 0.4512, 0.433, 0.354, 0.415),
        "pelvis":    SegmentRow("OMPH", "MIDH", 181.5, 0.1247, 0.4920, 0.433, 0.402, 0.444),
        "upper_arm": SegmentRow("SJC", "EJC", 275.1, 0.0255, 0.5754, 0.278, 0.260, 0.148),
        "forearm":   SegmentRow("EJC", "WJC", 264.3, 0.0138, 0.4559, 0.261, 0.257, 0.094),
        "hand":      SegmentRow("WJC", "MET3", 78.0, 0.0056, 0.7474, 0.531, 0.454, 0.335),
        "thigh":     SegmentRow("HJC", "KJC", 368.5, 0.1478, 0.3612, 0.369, 0.364, 0.162),
        "shank":     SegmentRow("KJC", "AJC", 438.6, 0.0481, 0.4352, 0.267, 0.263, 0.092),
        "foot":      SegmentRow("HEEL", "TTIP", 228.3, 0.0129, 0.4014, 0.299, 0.279, 0.139),
    }),
})

# Fractions of stature that de Leva does not give, with their sources.
STATURE_FRACTIONS = MappingProxyType({
    "male": MappingProxyType({
        "ankle_height": 0.039,         # Winter 2009 Fig. 4.1 (sole to ankle joint centre)
        "foot_width": 0.055,           # Winter 2009 Fig. 4.1
        "shoulder_width": 0.259,       # Winter 2009 Fig. 4.1 (biacromial)
        "hip_width": 0.191,            # Winter 2009 Fig. 4.1
        "hip_joint_half_width": 0.0457,   # ERD HumanLoader, HJC lateral offset (Dumas 2007)
        "shoulder_joint_half_width": 0.1164,  # ERD HumanLoader, SJC lateral offset
        "shoulder_joint_below_c7": 0.0416,    # ERD HumanLoader, SJC below the thorax origin
        "shoulder_joint_forward": 0.0046,     # ERD HumanLoader, SJC anterior offset
    }),
    "female": MappingProxyType({
        "ankle_height": 0.039,
        "foot_width": 0.055,
        "shoulder_width": 0.259,
        "hip_width": 0.191,
        "hip_joint_half_width": 0.0548,
        "shoulder_joint_half_width": 0.1108,
        "shoulder_joint_below_c7": 0.0449,
        "shoulder_joint_forward": 0.0043,
    }),
})
# fmt: on

# Design choice, no tabulated source found: the ankle joint centre lies above the point at this
# fraction of the foot length in front of the heel.
HEEL_TO_ANKLE_FRACTION = 0.25

# The toes segment of a body's foot (``toes=True``, the default: :func:`split_foot`), with sources.
# OPENSIM: gait2392 and Rajagopal 2016 (opensim-org/opensim-models): the mtp joint at
# x = 0.1788 m in the calcaneus frame, whose foot runs 0.2655 m from the heel (x = -0.0098) to
# the toe tip (0.2557, from the meshes; the scale marker set's heel and toe-tip markers give the
# same 0.71); toes 0.2166 kg of the calcaneus and toes' 1.4666 kg. Foot scans place the first
# MTP joint at 70-79 % of foot length.
# fmt: off
TOES = MappingProxyType({
    "mtp_fraction": 0.71,      # MTP joint from the heel, of the foot length: OPENSIM
    "mass_fraction": 0.148,    # toes' share of the foot mass: OPENSIM (0.2166 / 1.4666)
    "height_fraction": 0.5,    # toes' height, of the ankle height: design choice (their box
                               # and the MTP axis at its mid-height; the sole stays one plane)
})
# fmt: on

# The vertical chain from the sole to the vertex, bottom to top; see the closure rule above.
CHAIN = ("ankle_height", "shank", "thigh", "pelvis", "abdomen", "thorax", "head")
SEGMENT_NAMES = tuple(DE_LEVA_1996["male"])
# Segments whose long axis is horizontal (x forward) in the standing pose.
HORIZONTAL = frozenset({"foot"})


def _check_finite_range(name: str, value: float, lo: float, hi: float, unit: str) -> float:
    if isinstance(value, bool | str | bytes):  # float(True) and float("1.75") would pass
        raise BodyParameterError(f"{name} must be a number in [{lo}, {hi}] {unit}, got {value!r}")
    try:
        value = float(value)
    except (TypeError, ValueError, OverflowError):
        shown = repr(value) if len(repr(value)) < 40 else f"{repr(value)[:37]}..."
        raise BodyParameterError(
            f"{name} must be a number in [{lo}, {hi}] {unit}, got {shown}"
        ) from None
    if not math.isfinite(value) or not lo <= value <= hi:
        raise BodyParameterError(f"{name} must be in [{lo}, {hi}] {unit}, got {value!r}")
    return value


SIDES = ("left", "right")


@dataclass(frozen=True)
class JointRange:
    """Range of motion of one joint axis [deg], positive in the anatomical sense."""

    lower: float
    upper: float
    source: str


# Clinical ranges of motion.
# MERCK: Merck Manual "Normal Values for Range of Motion of Joints"; ROM-SHEET: "Normal ROM"
# sheet; KURZ: Kurz via yoga-age.com; 38CFR: 38 CFR 4.71a Note (2) normals (quoted, unverified),
# split evenly between the lumbar and thoracic joints for the thoracolumbar spine.
# fmt: off
JOINT_RANGES = MappingProxyType({
    "hip_flexion":        JointRange(-30.0, 125.0, "ROM-SHEET: flexion 125, extension 30"),
    "hip_adduction":      JointRange(-45.0, 25.0, "ROM-SHEET: abduction 45, adduction 25"),
    "hip_rotation":       JointRange(-45.0, 45.0, "MERCK: internal 45, external 45"),
    "knee":               JointRange(0.0, 140.0, "ROM-SHEET: flexion 140; no hyperextension"),
    "ankle_flexion":      JointRange(-50.0, 20.0, "MERCK: dorsiflexion 20, plantarflexion 50"),
    "ankle_inversion":    JointRange(-25.0, 35.0, "MERCK: inversion 35, eversion 25"),
    "lumbar_flexion":     JointRange(-15.0, 45.0, "38CFR/2: flexion 90, extension 30"),
    "lumbar_bending":     JointRange(-15.0, 15.0, "38CFR/2: lateral flexion 30"),
    "lumbar_rotation":    JointRange(-15.0, 15.0, "38CFR/2: rotation 30"),
    "thoracic_flexion":   JointRange(-15.0, 45.0, "38CFR/2: flexion 90, extension 30"),
    "thoracic_bending":   JointRange(-15.0, 15.0, "38CFR/2: lateral flexion 30"),
    "thoracic_rotation":  JointRange(-15.0, 15.0, "38CFR/2: rotation 30"),
    "neck_flexion":       JointRange(-45.0, 45.0, "38CFR: cervical flexion 45, extension 45"),
    "neck_bending":       JointRange(-45.0, 45.0, "38CFR: cervical lateral flexion 45"),
    "neck_rotation":      JointRange(-80.0, 80.0, "38CFR: cervical rotation 80"),
    "shoulder_flexion":   JointRange(-50.0, 180.0, "ROM-SHEET: flexion 180; MERCK: extension 50"),
    "shoulder_abduction": JointRange(-45.0, 180.0, "ROM-SHEET: abduction 180; KURZ: adduction 45"),
    "shoulder_rotation":  JointRange(-90.0, 90.0, "MERCK: internal 90, external 90"),
    "elbow":              JointRange(0.0, 145.0, "ROM-SHEET: flexion 145"),
    "wrist_flexion":      JointRange(-70.0, 80.0, "ROM-SHEET: flexion 80, extension 70"),
    "wrist_deviation":    JointRange(-45.0, 20.0, "ROM-SHEET: radial 20, ulnar 45"),
    "mtp":                JointRange(-45.0, 70.0, "AAOS normal first MTP: flexion 45, "
                                                   "extension 70 (OrthopaedicsOne)"),
})
# fmt: on


def range_names() -> tuple[str, ...]:
    """The names :class:`BodyParameters`' ``ranges`` takes: each joint kind (both sides, or the
    spine's and neck's one joint), then each sided joint (``left_ankle_flexion``)."""
    kinds = tuple(JOINT_RANGES)
    sided = [f"{s}_{k}" for s in SIDES for k in kinds
             if not k.startswith(("lumbar", "thoracic", "neck"))]  # fmt: skip
    return (*kinds, *sided)


def ranges_text(ranges: Mapping[str, tuple[float, float]]) -> str:
    """``ranges`` as the commands print them: ``ankle_flexion -50 to 30 deg, ...``."""
    return ", ".join(f"{k} {a:g} to {b:g} deg" for k, (a, b) in ranges.items())


def _checked_ranges(given) -> dict[str, tuple[float, float]]:
    """``ranges`` validated: known names, two finite numbers in [-180, 180] deg, lower first."""
    try:
        items = dict(given or {}).items()
    except (TypeError, ValueError):
        raise BodyParameterError(f"ranges must be a mapping of joint names to (lower, upper) "
                                 f"[deg], got {type(given).__name__}") from None  # fmt: skip
    valid = range_names()
    out = {}
    for key, value in items:
        if key not in valid:
            raise BodyParameterError(f"unknown joint range {key!r}; valid names: a kind "
                                     f"({', '.join(valid[:10])}, ...) or a sided joint "
                                     "(left_ankle_flexion, ...)")  # fmt: skip
        try:
            lower, upper = value
        except (TypeError, ValueError):
            raise BodyParameterError(f"ranges[{key!r}] must be (lower, upper) [deg], got "
                                     f"{value!r}") from None  # fmt: skip
        lower = _check_finite_range(f"ranges[{key!r}] lower", lower, -180.0, 180.0, "deg")
        upper = _check_finite_range(f"ranges[{key!r}] upper", upper, -180.0, 180.0, "deg")
        if not lower < upper:
            raise BodyParameterError(f"ranges[{key!r}]: the lower bound {lower:g} deg must be "
                                     f"below the upper {upper:g}")  # fmt: skip
        out[key] = (lower, upper)
    return out


@dataclass(frozen=True)
class BodyParameters:
    """A person: stature, mass and sex, validated on construction.

    Args:
        height: Stature, sole to vertex [m], in [0.5, 2.5].
        mass: Total body mass [kg], in [10, 300].
        sex: ``"male"`` or ``"female"`` (selects the de Leva table).
        segment_lengths: Optional measured lengths [m] that override the scaled ones, keyed by
            segment name (``head``, ``thorax``, ``abdomen``, ``pelvis``, ``upper_arm``,
            ``forearm``, ``hand``, ``thigh``, ``shank``, ``foot``) or ``ankle_height``.
            Measured chain lengths are kept; the others close the chain to the stature.
        toes: Split each foot at the metatarsophalangeal joint into a rearfoot and a toes
            segment on a hinge (:func:`split_foot`; the default); the two together keep de
            Leva's foot. False: one-piece feet.
        ranges: Optional ranges of motion [deg] (lower, upper) that override the clinical
            normals (:data:`JOINT_RANGES`), keyed by a joint's kind, for both sides
            (``ankle_flexion``), or by one joint (``right_ankle_flexion``): a subject's own,
            measured (a contracture, a crouch gait's dorsiflexion past 20 deg).

    Raises:
        BodyParameterError: a value is out of range, not finite, or of an unknown name.
    """

    height: float
    mass: float
    sex: str = "male"
    segment_lengths: Mapping[str, float] = field(default_factory=dict)
    toes: bool = True
    ranges: Mapping[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.toes, bool):
            raise BodyParameterError(f"toes must be True or False, got {self.toes!r}")
        object.__setattr__(
            self, "height", _check_finite_range("height", self.height, *HEIGHT_RANGE, "m")
        )
        object.__setattr__(self, "mass", _check_finite_range("mass", self.mass, *MASS_RANGE, "kg"))
        if self.sex not in SEXES:
            raise BodyParameterError(f"sex must be one of {SEXES}, got {self.sex!r}")
        valid = (*SEGMENT_NAMES, "ankle_height")
        lengths = {}
        try:
            given = dict(self.segment_lengths or {})
        except (TypeError, ValueError):
            raise BodyParameterError(
                f"segment_lengths must be a mapping of names to lengths, got "
                f"{type(self.segment_lengths).__name__}"
            ) from None
        for key, value in given.items():
            if key not in valid:
                raise BodyParameterError(
                    f"unknown segment length {key!r}; valid names: {', '.join(valid)}"
                )
            lengths[key] = _check_finite_range(
                f"segment_lengths[{key!r}]", value, 0.005, 0.6 * self.height, "m"
            )
        object.__setattr__(self, "segment_lengths", MappingProxyType(lengths))
        object.__setattr__(self, "ranges", MappingProxyType(_checked_ranges(self.ranges)))
        body_dimensions(self)  # raises if the measured lengths cannot close the chain

    def __hash__(self) -> int:
        lengths = tuple(sorted(self.segment_lengths.items()))
        return hash((self.height, self.mass, self.sex, lengths, self.toes,
                     tuple(sorted(self.ranges.items()))))  # fmt: skip


@dataclass(frozen=True)
class Segment:
    """One body segment scaled to a person, in its own frame (x forward, y left, z up).

    Attributes:
        name: Segment name (``thigh``, ``foot``...), the same for left and right.
        length: Segment length [m] (origin to end landmark).
        mass: Segment mass [kg].
        com_fraction: CoM position from the origin landmark as a fraction of ``length`` [-].
        inertia: Principal moments about the CoM along (x, y, z) [kg m^2].
        row: The de Leva table row it comes from.
    """

    name: str
    length: float
    mass: float
    com_fraction: float
    inertia: tuple[float, float, float]
    row: SegmentRow


def body_dimensions(params: BodyParameters) -> dict[str, float]:
    """Lengths [m] of the segments and of the other dimensions for a person.

    The chain elements (see :data:`CHAIN`) sum to ``params.height`` exactly.

    Returns:
        A dict with every segment name, ``ankle_height`` and the widths of
        :data:`STATURE_FRACTIONS`, plus ``chain_scale``: the common factor applied to the
        unmeasured chain elements (1.0 means de Leva's proportions add up to the stature).
    """
    h = params.height
    sex = params.sex
    ref_h = REFERENCE_SUBJECT[sex][0]
    dims = {name: row.length_mm / 1000.0 / ref_h * h for name, row in DE_LEVA_1996[sex].items()}
    dims.update({k: f * h for k, f in STATURE_FRACTIONS[sex].items()})
    measured = dict(params.segment_lengths)
    fixed = sum(measured[k] for k in CHAIN if k in measured)
    free = sum(dims[k] for k in CHAIN if k not in measured)
    if free <= 0.0:
        if abs(fixed - h) > 1e-9 * h:
            raise BodyParameterError(
                f"the measured chain {', '.join(CHAIN)} sums to {fixed:.4f} m, "
                f"not the height {h:.4f} m"
            )
        scale = 1.0
    else:
        scale = (h - fixed) / free
    if not 0.8 <= scale <= 1.25:
        raise BodyParameterError(
            f"measured segment lengths leave {h - fixed:.3f} m of the {h:.3f} m stature for the "
            f"other chain segments ({', '.join(k for k in CHAIN if k not in measured)}), which "
            f"would scale them by {scale:.2f}; valid is 0.8 to 1.25"
        )
    for k in CHAIN:
        if k not in measured:
            dims[k] *= scale
    dims.update(measured)
    dims["chain_scale"] = scale
    return dims


def segments(params: BodyParameters) -> dict[str, Segment]:
    """The ten segment kinds scaled to a person (limbs once; the body has two of each).

    Masses are the table fractions times the body mass, renormalised by the sum of the
    fractions over the whole body (1.0000 for de Leva's male table, 0.9999 for the female one:
    rounding in the table), so that the segment masses add up to ``params.mass`` exactly.

    Returns:
        Segments keyed by name, in the order of :data:`DE_LEVA_1996`.
    """
    table = DE_LEVA_1996[params.sex]
    dims = body_dimensions(params)
    total_fraction = mass_fraction_sum(params.sex)
    out = {}
    for name, row in table.items():
        length = dims[name]
        mass = params.mass * row.mass / total_fraction
        r = np.array([row.r_sag, row.r_trans, row.r_long]) * length
        if name in HORIZONTAL:  # long axis along x: (long, sag, trans) on (x, y, z), Gurchiek
            r = np.array([row.r_long, row.r_sag, row.r_trans]) * length
        ixx, iyy, izz = (float(v) for v in mass * r**2)
        inertia = (ixx, iyy, izz)
        out[name] = Segment(name, length, mass, row.com, inertia, row)
    return out


# Segments that appear twice in the body (left and right).
BILATERAL = frozenset({"upper_arm", "forearm", "hand", "thigh", "shank", "foot"})


def mass_fraction_sum(sex: str) -> float:
    """Sum of de Leva's mass fractions over the whole body (bilateral segments twice) [-]."""
    table = DE_LEVA_1996[sex]
    return sum(row.mass * (2 if name in BILATERAL else 1) for name, row in table.items())


@dataclass(frozen=True)
class FootParts:
    """De Leva's foot split at the metatarsophalangeal (MTP) joint, in a frame at the heel on
    the sole (x forward along the foot, y left, z up) [m, kg, kg m^2].

    The toes are a uniform box from the MTP joint to the toe tip, the foot's width and
    ``toes_height`` tall; the rearfoot is the rest: its mass, CoM and inertia are what the whole
    foot's minus the toes' leave, so that at an MTP angle of zero the two parts have exactly de
    Leva's foot mass, CoM and inertia about its CoM.

    Attributes:
        mtp_x: The MTP joint (the metatarsal heads) from the heel.
        joint_z: The MTP axis above the sole (the toes' mid-height).
        toes_height: The toes box's height.
        rear_mass, rear_com, rear_inertia: The rearfoot (inertia 3x3 about its CoM).
        toes_mass, toes_com, toes_inertia: The toes (inertia 3x3 about their CoM).
    """

    mtp_x: float
    joint_z: float
    toes_height: float
    rear_mass: float
    rear_com: np.ndarray
    rear_inertia: np.ndarray
    toes_mass: float
    toes_com: np.ndarray
    toes_inertia: np.ndarray


def _parallel_axis(mass: float, d: np.ndarray) -> np.ndarray:
    """The inertia of a point mass at offset d: m (|d|^2 E - d d^T)."""
    return mass * (float(d @ d) * np.eye(3) - np.outer(d, d))


def split_foot(foot: Segment, width: float, ankle_height: float) -> FootParts:
    """The foot split into a rearfoot and toes (see :class:`FootParts` and :data:`TOES`).

    Args:
        foot: The de Leva foot (heel to toe tip; its CoM ``ankle_height / 2`` above the sole,
            as the body places it).
        width: Foot width [m].
        ankle_height: Sole to ankle joint centre [m].
    """
    L, m = foot.length, foot.mass
    mtp_x = TOES["mtp_fraction"] * L
    toes_len, toes_h = L - mtp_x, TOES["height_fraction"] * ankle_height
    m_t = TOES["mass_fraction"] * m
    c = np.array([foot.com_fraction * L, 0.0, ankle_height / 2])
    c_t = np.array([mtp_x + toes_len / 2, 0.0, toes_h / 2])
    I_t = (m_t / 12.0) * np.diag(
        [width**2 + toes_h**2, toes_len**2 + toes_h**2, toes_len**2 + width**2]
    )
    m_r = m - m_t
    c_r = (m * c - m_t * c_t) / m_r
    # about the whole foot's CoM: I = I_r + m_r d_r^2-terms + I_t + m_t d_t^2-terms
    I_r = np.diag(foot.inertia) - _parallel_axis(m_r, c_r - c) - I_t - _parallel_axis(m_t, c_t - c)
    if np.linalg.eigvalsh(I_r).min() <= 0.0:
        raise BodyParameterError(
            f"the rearfoot's inertia is not positive definite ({np.linalg.eigvalsh(I_r)}): "
            "the toes take more of the foot's inertia than it has"
        )
    return FootParts(mtp_x, toes_h / 2, toes_h, m_r, c_r, I_r, m_t, c_t, I_t)
