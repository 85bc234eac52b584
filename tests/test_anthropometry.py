"""Body segment parameters: validation, chain closure, de Leva masses and inertias.

The de Leva (1996) Table 4 numbers below are typed in independently of
``humanoid.anthropometry`` (cross-checked against R. Gurchiek's ``deleva.m`` transcription of
the table), so a typo in the library's table fails these tests.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import humanoid
from humanoid import anthropometry
from humanoid.anthropometry import (
    CHAIN,
    DE_LEVA_1996,
    BodyParameters,
    body_dimensions,
    mass_fraction_sum,
    segments,
)
from humanoid.errors import BodyParameterError

SEXES = ("male", "female")
HYPOTHESIS = settings(max_examples=50, derandomize=True, deadline=None)
REL = 1e-12  # relative tolerance of the closed-form identities below

# de Leva 1996 Table 4, as printed: length [mm], mass fraction, CoM fraction from the origin,
# radii of gyration (sagittal, transverse, longitudinal) as fractions of the length.
# head = "Head 2" (VERT-CERV), thorax = "Upper trunk 2" (CERV-XYPH), shank = "Shank 2" (KJC-AJC).
# fmt: off
TABLE4 = {
    "male": {
        "head":      (242.9, 0.0694, 0.5002, 0.303, 0.315, 0.261),
        "thorax":    (242.1, 0.1596, 0.5066, 0.505, 0.320, 0.465),
        "abdomen":   (215.5, 0.1633, 0.4502, 0.482, 0.383, 0.468),
        "pelvis":    (145.7, 0.1117, 0.6115, 0.615, 0.551, 0.587),
        "upper_arm": (281.7, 0.0271, 0.5772, 0.285, 0.269, 0.158),
        "forearm":   (268.9, 0.0162, 0.4574, 0.276, 0.265, 0.121),
        "hand":      (86.2,  0.0061, 0.7900, 0.628, 0.513, 0.401),
        "thigh":     (422.2, 0.1416, 0.4095, 0.329, 0.329, 0.149),
        "shank":     (440.3, 0.0433, 0.4395, 0.251, 0.246, 0.102),
        "foot":      (258.1, 0.0137, 0.4415, 0.257, 0.245, 0.124),
    },
    "female": {
        "head":      (243.7, 0.0668, 0.4841, 0.271, 0.295, 0.261),
        "thorax":    (228.0, 0.1545, 0.5050, 0.466, 0.314, 0.449),
        "abdomen":   (205.3, 0.1465, 0.4512, 0.433, 0.354, 0.415),
        "pelvis":    (181.5, 0.1247, 0.4920, 0.433, 0.402, 0.444),
        "upper_arm": (275.1, 0.0255, 0.5754, 0.278, 0.260, 0.148),
        "forearm":   (264.3, 0.0138, 0.4559, 0.261, 0.257, 0.094),
        "hand":      (78.0,  0.0056, 0.7474, 0.531, 0.454, 0.335),
        "thigh":     (368.5, 0.1478, 0.3612, 0.369, 0.364, 0.162),
        "shank":     (438.6, 0.0481, 0.4352, 0.267, 0.263, 0.092),
        "foot":      (228.3, 0.0129, 0.4014, 0.299, 0.279, 0.139),
    },
}
# fmt: on
REFERENCE_STATURE = {"male": 1.741, "female": 1.735}  # de Leva's reference subjects [m]
BILATERAL = ("upper_arm", "forearm", "hand", "thigh", "shank", "foot")
# Sum of the mass fractions over the whole body, added up by hand from Table 4.
FRACTION_SUM = {"male": 1.0000, "female": 0.9999}


def _close(a: float, b: float, rel: float = REL) -> bool:
    return math.isclose(a, b, rel_tol=rel, abs_tol=0.0)


# --- validation --------------------------------------------------------------------------------


def test_body_parameter_error_is_a_humanoid_error():
    assert issubclass(BodyParameterError, humanoid.HumanoidError)
    assert humanoid.BodyParameterError is BodyParameterError
    with pytest.raises(humanoid.HumanoidError):
        BodyParameters(3.0, 70.0)


@pytest.mark.parametrize("height", [0.0, 0.4999, 2.5001, 3.0, -1.75, 1e300])
def test_height_out_of_range(height):
    with pytest.raises(BodyParameterError, match=r"height must be in \[0\.5, 2\.5\] m"):
        BodyParameters(height, 70.0)


@pytest.mark.parametrize("mass", [0.0, 9.99, 300.01, 1000.0, -70.0])
def test_mass_out_of_range(mass):
    with pytest.raises(BodyParameterError, match=r"mass must be in \[10(\.0)?, 300(\.0)?\] kg"):
        BodyParameters(1.75, mass)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_height_and_mass(bad):
    with pytest.raises(BodyParameterError, match=r"height must be in \[0\.5, 2\.5\] m, got"):
        BodyParameters(bad, 70.0)
    with pytest.raises(BodyParameterError, match=r"mass must be in \[10(\.0)?, 300(\.0)?\] kg"):
        BodyParameters(1.75, bad)


@pytest.mark.parametrize("bad", ["tall", "", "1.7 m", None, [1.75]])
def test_non_numeric_height_and_mass(bad):
    with pytest.raises(BodyParameterError, match=r"height must be a number in \[0\.5, 2\.5\] m"):
        BodyParameters(bad, 70.0)
    with pytest.raises(
        BodyParameterError, match=r"mass must be a number in \[10(\.0)?, 300(\.0)?\] kg"
    ):
        BodyParameters(1.75, bad)


def test_range_bounds_are_inclusive():
    for h in (0.5, 2.5):
        for m in (10.0, 300.0):
            p = BodyParameters(h, m)
            assert (p.height, p.mass) == (h, m)


@pytest.mark.parametrize("sex", ["Male", "m", "F", "other", "", None])
def test_unknown_sex(sex):
    with pytest.raises(BodyParameterError, match=r"sex must be one of \('male', 'female'\)"):
        BodyParameters(1.75, 70.0, sex)


def test_unknown_segment_length_key_lists_the_valid_names():
    with pytest.raises(BodyParameterError, match=r"unknown segment length 'femur'") as info:
        BodyParameters(1.75, 70.0, segment_lengths={"femur": 0.45})
    for name in ("thigh", "shank", "foot", "ankle_height", "head"):
        assert name in str(info.value)


@pytest.mark.parametrize("length", [0.001, 1.2, math.nan, math.inf])
def test_segment_length_out_of_range(length):
    # the valid range is 0.005 m to 0.6 x stature (1.05 m at 1.75 m)
    with pytest.raises(
        BodyParameterError, match=r"segment_lengths\['thigh'\] must be in \[0\.005, 1\.05\] m"
    ):
        BodyParameters(1.75, 70.0, segment_lengths={"thigh": length})


def test_measured_lengths_that_leave_too_little_for_the_chain():
    # a 1.0 m thigh leaves 0.75 m for the other chain elements (about 1.3 m unscaled)
    with pytest.raises(BodyParameterError, match=r"would scale them by 0\.\d\d; valid is 0\.8 to"):
        BodyParameters(1.75, 70.0, segment_lengths={"thigh": 1.0})
    # short thigh and shank leave too much
    with pytest.raises(BodyParameterError, match=r"would scale them by 1\.\d\d; valid is 0\.8 to"):
        BodyParameters(1.75, 70.0, segment_lengths={"thigh": 0.1, "shank": 0.1})


@pytest.mark.parametrize("scale, valid", [(0.79, False), (0.81, True), (1.24, True), (1.26, False)])
def test_the_chain_scale_is_bounded_at_0_8_and_1_25(scale, valid):
    """Measured thigh and shank that leave the other chain elements ``scale`` times their de
    Leva share: refused just outside 0.8-1.25, accepted just inside (a planted bound of 1.5
    passed the test above, whose short legs ask 1.6)."""
    h = 1.75
    d = body_dimensions(BodyParameters(h, 70.0))
    raw = {k: d[k] / d["chain_scale"] for k in CHAIN}  # the unscaled chain elements
    free = sum(raw[k] for k in CHAIN if k not in ("thigh", "shank"))
    fixed = h - scale * free
    legs = raw["thigh"] + raw["shank"]
    lengths = {k: fixed * raw[k] / legs for k in ("thigh", "shank")}
    if valid:
        got = body_dimensions(BodyParameters(h, 70.0, segment_lengths=lengths))
        assert got["chain_scale"] == pytest.approx(scale, rel=1e-9)
    else:
        with pytest.raises(BodyParameterError, match=rf"would scale them by {scale:.2f}; valid"):
            BodyParameters(h, 70.0, segment_lengths=lengths)


def test_fully_measured_chain_must_sum_to_the_height():
    lengths = {
        "ankle_height": 0.07,
        "shank": 0.43,
        "thigh": 0.42,
        "pelvis": 0.15,
        "abdomen": 0.21,
        "thorax": 0.24,
        "head": 0.24,
    }  # sums to 1.76 m
    with pytest.raises(BodyParameterError, match=r"sums to 1\.7600 m, not the height 1\.7500 m"):
        BodyParameters(1.75, 70.0, segment_lengths=lengths)
    p = BodyParameters(1.76, 70.0, segment_lengths=lengths)
    assert body_dimensions(p)["thigh"] == 0.42


@HYPOTHESIS
@given(
    height=st.floats(0.5, 2.5),
    mass=st.floats(10.0, 300.0),
    sex=st.sampled_from(SEXES),
)
def test_any_height_and_mass_in_range_construct(height, mass, sex):
    p = BodyParameters(height, mass, sex)
    assert (p.height, p.mass, p.sex) == (height, mass, sex)
    assert _close(sum(body_dimensions(p)[k] for k in CHAIN), height)


OUT_OF_RANGE_HEIGHT = st.floats(allow_nan=True, allow_infinity=True).filter(
    lambda x: not 0.5 <= x <= 2.5
)
OUT_OF_RANGE_MASS = st.floats(allow_nan=True, allow_infinity=True).filter(
    lambda x: not 10.0 <= x <= 300.0
)


@HYPOTHESIS
@given(height=OUT_OF_RANGE_HEIGHT)
def test_any_height_out_of_range_raises(height):
    with pytest.raises(BodyParameterError, match=r"height must be in \[0\.5, 2\.5\] m"):
        BodyParameters(height, 70.0)


@HYPOTHESIS
@given(mass=OUT_OF_RANGE_MASS)
def test_any_mass_out_of_range_raises(mass):
    with pytest.raises(BodyParameterError, match=r"mass must be in \[10(\.0)?, 300(\.0)?\] kg"):
        BodyParameters(1.75, mass)


# --- chain closure -----------------------------------------------------------------------------


@pytest.mark.parametrize("sex", SEXES)
@pytest.mark.parametrize("height", [0.5, 1.0, 1.55, 1.741, 1.9, 2.5])
def test_chain_sums_to_height(sex, height):
    d = body_dimensions(BodyParameters(height, 70.0, sex))
    total = sum(d[k] for k in CHAIN)
    assert _close(total, height), f"chain sums to {total!r}, height {height!r}"


@pytest.mark.parametrize("sex", SEXES)
def test_chain_scale_matches_de_leva_proportions(sex):
    # Unscaled chain = ankle height (0.039 x stature, Winter) + de Leva's chain lengths; the
    # docstring: the male chain is 2.0 % long, the female one 0.1 % short.
    ref = REFERENCE_STATURE[sex]
    unscaled = 0.039 + sum(TABLE4[sex][k][0] for k in CHAIN if k != "ankle_height") / 1000 / ref
    d = body_dimensions(BodyParameters(1.8, 80.0, sex))
    assert _close(d["chain_scale"], 1.0 / unscaled)
    expected_excess = {"male": 0.020, "female": -0.001}[sex]
    assert abs(unscaled - 1.0 - expected_excess) < 5e-4
    # limbs are scaled by stature only, not by the chain factor
    for name in ("upper_arm", "forearm", "hand", "foot"):
        assert _close(d[name], TABLE4[sex][name][0] / 1000 / ref * 1.8), name
    for name in ("thigh", "shank", "head"):
        assert _close(d[name], TABLE4[sex][name][0] / 1000 / ref * 1.8 / unscaled), name


@pytest.mark.parametrize("sex", SEXES)
@pytest.mark.parametrize("height", [1.5, 1.75, 2.0])
def test_measured_override_is_kept_and_chain_still_closes(sex, height):
    p = BodyParameters(height, 70.0, sex, segment_lengths={"thigh": 0.5})
    d = body_dimensions(p)
    assert d["thigh"] == 0.5
    assert _close(sum(d[k] for k in CHAIN), height)
    free = [k for k in CHAIN if k != "thigh"]
    # the other chain elements keep de Leva's proportions among themselves
    plain = body_dimensions(BodyParameters(height, 70.0, sex))
    ratios = [d[k] / plain[k] for k in free]
    assert max(ratios) - min(ratios) < 1e-12
    assert _close(sum(d[k] for k in free), height - 0.5)


def test_two_overrides_and_ankle_height():
    lengths = {"shank": 0.41, "ankle_height": 0.08, "upper_arm": 0.3}
    p = BodyParameters(1.7, 65.0, "female", segment_lengths=lengths)
    d = body_dimensions(p)
    for k, v in lengths.items():
        assert d[k] == v
    assert _close(sum(d[k] for k in CHAIN), 1.7)


# --- mass fractions ----------------------------------------------------------------------------


@pytest.mark.parametrize("sex", SEXES)
def test_mass_fraction_sum(sex):
    total = mass_fraction_sum(sex)
    assert abs(total - 1.0) <= 2e-4
    assert abs(total - FRACTION_SUM[sex]) < 1e-12


@pytest.mark.parametrize("sex", SEXES)
@pytest.mark.parametrize(("height", "mass"), [(1.75, 75.0), (1.5, 48.0), (2.1, 130.0)])
def test_segment_mass_fractions(sex, height, mass):
    p = BodyParameters(height, mass, sex)
    segs = segments(p)
    assert tuple(segs) == tuple(TABLE4[sex])
    for name, seg in segs.items():
        expected = TABLE4[sex][name][1] / FRACTION_SUM[sex]
        assert _close(seg.mass / p.mass, expected), name
        assert _close(seg.mass / p.mass, DE_LEVA_1996[sex][name].mass / mass_fraction_sum(sex))
    whole = sum(s.mass * (2 if n in BILATERAL else 1) for n, s in segs.items())
    assert _close(whole, mass), f"segment masses sum to {whole!r}, body mass {mass!r}"


@pytest.mark.parametrize("sex", SEXES)
def test_de_leva_table_against_table4_literals(sex):
    table = DE_LEVA_1996[sex]
    assert set(table) == set(TABLE4[sex])
    for name, (length, mass, com, r_sag, r_trans, r_long) in TABLE4[sex].items():
        row = table[name]
        got = (row.length_mm, row.mass, row.com, row.r_sag, row.r_trans, row.r_long)
        assert got == (length, mass, com, r_sag, r_trans, r_long), name
    assert anthropometry.REFERENCE_SUBJECT[sex][0] == REFERENCE_STATURE[sex]


def test_spot_values_of_table4():
    male, female = DE_LEVA_1996["male"], DE_LEVA_1996["female"]
    assert male["thigh"].mass == 0.1416
    assert male["thigh"].com == 0.4095
    assert male["head"].mass == 0.0694  # Head 2, VERT-CERV
    assert male["head"].length_mm == 242.9
    assert female["shank"].length_mm == 438.6  # Shank 2, KJC-AJC
    assert female["shank"].com == 0.4352
    assert female["thigh"].r_long == 0.162
    assert male["foot"].r_sag == 0.257
    assert anthropometry.REFERENCE_SUBJECT["female"] == (1.735, 61.9)
    assert anthropometry.REFERENCE_SUBJECT["male"] == (1.741, 73.0)


@pytest.mark.parametrize("sex", SEXES)
def test_segment_com_and_length(sex):
    p = BodyParameters(1.68, 60.0, sex)
    segs, d = segments(p), body_dimensions(p)
    for name, seg in segs.items():
        assert seg.com_fraction == TABLE4[sex][name][2]
        assert seg.length == d[name]


# --- inertia -----------------------------------------------------------------------------------


@pytest.mark.parametrize("sex", SEXES)
@pytest.mark.parametrize(("height", "mass"), [(1.75, 75.0), (1.6, 55.0)])
def test_thigh_inertia(sex, height, mass):
    p = BodyParameters(height, mass, sex)
    thigh = segments(p)["thigh"]
    L = body_dimensions(p)["thigh"]
    m = mass * TABLE4[sex]["thigh"][1] / FRACTION_SUM[sex]
    r_sag, r_trans, r_long = TABLE4[sex]["thigh"][3:]
    # upright segment: sagittal radius about x, transverse about y, longitudinal about z
    expected = (m * (r_sag * L) ** 2, m * (r_trans * L) ** 2, m * (r_long * L) ** 2)
    for axis, got, want in zip("xyz", thigh.inertia, expected, strict=True):
        assert _close(got, want), f"I{axis}{axis}: {got} != {want}"


@pytest.mark.parametrize("sex", SEXES)
@pytest.mark.parametrize(("height", "mass"), [(1.75, 75.0), (1.6, 55.0)])
def test_foot_inertia_has_its_long_axis_forward(sex, height, mass):
    p = BodyParameters(height, mass, sex)
    foot = segments(p)["foot"]
    L = TABLE4[sex]["foot"][0] / 1000 / REFERENCE_STATURE[sex] * height
    m = mass * TABLE4[sex]["foot"][1] / FRACTION_SUM[sex]
    r_sag, r_trans, r_long = TABLE4[sex]["foot"][3:]
    # horizontal segment (Gurchiek's mapping): longitudinal on x, sagittal on y, transverse on z
    expected = (m * (r_long * L) ** 2, m * (r_sag * L) ** 2, m * (r_trans * L) ** 2)
    for axis, got, want in zip("xyz", foot.inertia, expected, strict=True):
        assert _close(got, want), f"I{axis}{axis}: {got} != {want}"
    # the smallest moment is about the foot's long (forward) axis
    assert foot.inertia[0] == min(foot.inertia)


@pytest.mark.parametrize("value", [True, False, "1.75", b"1.75"])
def test_booleans_and_strings_are_not_numbers(value):
    with pytest.raises(BodyParameterError, match=r"height must be a number in \[0.5, 2.5\] m"):
        BodyParameters(value, 70.0, "male")
