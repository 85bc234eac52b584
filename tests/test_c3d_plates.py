"""C3D force plates (humanoid.motion.c3d): known loads, written as each plate type's raw
channels by the inverse of the C3D guide's formulas, read back.

Every trial here is written with ezc3d: a ground reaction force that rises and falls along a
plate, its centre of pressure moving heel to toe and a free moment, made into the channels a
type 1, 2, 3 or 4 plate records (the plate's wrench on the subject in its axes, z down, as
real Qualisys, BTS and Kistler files hold it; moments about the transducer's origin below the
surface, a type 4's channels through the inverse of a full calibration matrix, a Kistler's
eight sensor forces), scaled by ``ANALOG:SCALE`` and shifted by ``ANALOG:OFFSET``
and ``GEN_SCALE`` (patched into the file: ezc3d writes them as 0 and 1). The channels are
stored as 32-bit floats: what comes back is the load to a millionth of its size (forces to
1e-6 of the peak force, centres of pressure to 1e-6 m, free moments to 1e-6 of the peak force
times a metre), and ezc3d's own reading of a type 2 and a type 4 plate agrees to rounding.
"""

from __future__ import annotations

import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import get_model

from humanoid.errors import HumanoidError
from humanoid.motion import MotionFileError
from humanoid.motion.c3d import (
    PlateWarning,
    assign_contacts,
    c3d_loads,
    foot_markers,
    plate_loads,
    read_events,
    read_plates,
)
from humanoid.motion.c3d_file import parameter_table
from humanoid.motion.loads import OPENSIM_TO_OURS, read_loads
from humanoid.motion.markers import read_c3d

RATE, SUB, FRAMES = 100.0, 10, 100  # marker rate [Hz], analog samples per frame, frames
TIME = np.arange(FRAMES * SUB) / (RATE * SUB)
PEAK = 700.0  # [N], the vertical force's peak
UP = np.array([0.0, 0.0, 1.0])
# a type 4 plate's calibration matrix: N/V in its first three rows, N mm/V in the others,
# cross-talk in every off-diagonal entry and no symmetry
_rng = np.random.default_rng(7)
_D = np.array([2.0, 2.5, 0.5, 300.0, 250.0, 150.0])
CAL = np.diag(_D) + 0.05 * _D[:, None] * _rng.uniform(-1.0, 1.0, (6, 6)) * (1 - np.eye(6))


# -- writing trials ------------------------------------------------------------------------


def _plate(kind, centre, yaw, origin_mm, window, cop0, cop1, channels):
    """A plate of the trial: its type, the top surface's centre (ours) [m], its x axis's
    heading [deg] (its z down), ORIGIN as stored [mm], the contact's window [s], the centre of
    pressure's path (ours, xy) [m] and its analog channel numbers."""
    return dict(type=kind, centre=np.array(centre, float), yaw=yaw,
                origin=np.array(origin_mm, float), window=window, cop0=np.array(cop0, float),
                cop1=np.array(cop1, float), channels=list(channels))  # fmt: skip


def _axes(yaw):
    """The plate's axes in ours (columns x, y, z): x heading ``yaw``, z down."""
    x = np.array([np.cos(np.radians(yaw)), np.sin(np.radians(yaw)), 0.0])
    z = -UP
    return np.column_stack([x, np.cross(z, x), z])


def _known(p):
    """The plate's known load in ours: ground reaction (n, 3) [N], centre of pressure (n, 3)
    [m] and free moment about the vertical (n,) [N m]; zero force outside its window."""
    t0, t1 = p["window"]
    s = np.clip((TIME - t0) / (t1 - t0), 0.0, 1.0)
    inside = (TIME > t0) & (TIME < t1)
    fz = np.where(inside, PEAK * np.sin(np.pi * s), 0.0)
    f = np.column_stack([0.15 * fz * np.cos(np.pi * s), 0.04 * fz + 0.02 * fz * s, fz])
    xy = p["cop0"] + np.outer(s, p["cop1"] - p["cop0"])
    cop = np.column_stack([xy, np.full(len(TIME), p["centre"][2])])
    tau = np.where(inside, 4.0 * np.sin(2 * np.pi * s) * np.sin(np.pi * s), 0.0)
    return f, cop, tau


def _channels(p):
    """The raw channels (n, 6 or 8) the plate records for its known load, and their units."""
    f, cop, tau = _known(p)
    R = _axes(p["yaw"])
    F = f @ R  # the plate's force on the subject, plate axes
    r = (cop - p["centre"]) @ R  # the centre of pressure from the surface's centre
    assert np.abs(r[:, 2]).max() < 1e-12
    T = (tau[:, None] * UP) @ R[:, 2]
    MP = np.cross(r, F) + T[:, None] * np.array([0.0, 0.0, 1.0])  # about the surface's centre
    o = p["origin"] * 1e-3
    if p["type"] in (2, 4) and o[2] > 0:
        o = -o  # stored from the surface to the origin (old AMTI sheets)
    length, moment = p.get("units", ("mm", "Nmm"))  # of type 1's Px Py, types 1 and 2's moments
    per_m, per_nm = {"mm": 1e3, "m": 1.0}[length], {"Nmm": 1e3, "N.m": 1.0}[moment]
    if p["type"] == 1:
        ch = np.column_stack([F, r[:, :2] * per_m, T * per_nm])
        return ch, ["N"] * 3 + [length, length, moment]
    if p["type"] == 3:
        a, b = o[:2]
        o = np.array([0.0, 0.0, -abs(o[2])])
        MO = MP - np.cross(F, o)
        # Kistler's channels fx12 fx34 fy14 fy23 fz1..fz4 to (F, M about the sensors' centre)
        A = np.zeros((6, 8))
        A[0, [0, 1]] = 1.0
        A[1, [2, 3]] = 1.0
        A[2, 4:] = 1.0
        A[3, 4:] = b * np.array([1.0, 1.0, -1.0, -1.0])
        A[4, 4:] = a * np.array([-1.0, 1.0, 1.0, -1.0])
        A[5, :4] = [-b, b, a, -a]
        ch = np.linalg.pinv(A) @ np.hstack([F, MO]).T
        return ch.T, ["N"] * 8
    MO = MP - np.cross(F, o)  # about the transducer's origin [N m]
    if p["type"] == 4:  # N, and N mm: the lab's millimetres
        return np.linalg.solve(CAL, np.hstack([F, MO * 1e3]).T).T, ["V"] * 6
    return np.hstack([F, MO * per_nm]), ["N"] * 3 + [moment] * 3


def _write(path, plates, markers=None, y_up=False, events=(), gen_scale=0.5, patch=None,
           edit=None):  # fmt: skip
    """Write the trial (``plates``: :func:`_plate` specs; ``markers``: {name: (frames, 3) or
    (3,) ours [m]}; ``y_up``: a Y-up lab, POINT:Y_SCREEN +Y). Two unused channels come
    first; every channel has its own SCALE and OFFSET; ``patch(c)`` edits the parameters,
    ``edit(signals)`` the channels (channels, samples) as they are to be read."""
    import ezc3d

    L = OPENSIM_TO_OURS.T if y_up else np.eye(3)  # ours to the lab's
    n_channels = 2 + sum(len(p["channels"]) for p in plates)
    signals = np.zeros((n_channels, len(TIME)))
    units = ["V", "V"] + [""] * (n_channels - 2)
    signals[0] = np.sin(TIME)  # an EMG, say
    for p in plates:
        ch, u = _channels(p)
        for k, number in enumerate(p["channels"]):
            signals[number - 1] = ch[:, k]
            units[number - 1] = u[k]
    if edit is not None:
        edit(signals)
    scale = 0.25 + 0.125 * (np.arange(n_channels) % 7)
    offset = 3 + (np.arange(n_channels) * 5) % 11
    c = ezc3d.c3d()
    point = c["parameters"]["POINT"]
    point["RATE"]["value"] = np.array([RATE])
    point["UNITS"]["value"] = ["mm"]
    markers = markers or {"A": np.zeros(3)}
    point["LABELS"]["value"] = list(markers)
    pts = np.zeros((4, len(markers), FRAMES))
    pts[3] = 1.0
    for k, xyz in enumerate(markers.values()):
        pts[:3, k] = (np.broadcast_to(xyz, (FRAMES, 3)) @ L.T * 1e3).T
    c["data"]["points"] = pts
    if y_up:
        c.add_parameter("POINT", "Y_SCREEN", ["+Y"])
    analog = c["parameters"]["ANALOG"]
    analog["RATE"]["value"] = np.array([RATE * SUB])
    analog["LABELS"]["value"] = [f"ch{i + 1}" for i in range(n_channels)]
    analog["SCALE"]["value"] = scale
    analog["UNITS"]["value"] = units
    # read back: (stored - OFFSET) SCALE GEN_SCALE with stored = written / SCALE
    c["data"]["analogs"] = (signals / gen_scale + offset[:, None] * scale[:, None])[None]
    fp = c["parameters"]["FORCE_PLATFORM"]
    used = len(plates)
    fp["USED"]["value"] = np.array([used])
    fp["TYPE"]["value"] = np.array([p["type"] for p in plates])
    corners = np.zeros((3, 4, used))
    quadrants = [(1, 1), (-1, 1), (-1, -1), (1, -1)]
    for k, p in enumerate(plates):
        R = _axes(p["yaw"])
        for j, (sx, sy) in enumerate(quadrants):
            corners[:, j, k] = L @ (p["centre"] + R @ np.array([0.3 * sx, 0.2 * sy, 0.0])) * 1e3
    fp["CORNERS"]["value"] = corners
    fp["ORIGIN"]["value"] = np.column_stack([p["origin"] for p in plates])
    width = max(len(p["channels"]) for p in plates)
    channel = np.zeros((width, used), dtype=int)
    for k, p in enumerate(plates):
        channel[: len(p["channels"]), k] = p["channels"]
    fp["CHANNEL"]["value"] = channel
    cal = np.zeros((6, 6, used))
    for k, p in enumerate(plates):
        cal[:, :, k] = CAL if p["type"] == 4 else np.eye(6)
    fp["CAL_MATRIX"]["value"] = cal
    for t, context, label in events:
        c.add_event([int(t // 60), float(t % 60)], context=context, label=label)
    if patch is not None:
        patch(c)
    c.write(str(path))
    buf = bytearray(Path(path).read_bytes())
    assert buf[(buf[0] - 1) * 512 + 3] == 84  # Intel: packed little-endian below
    found = parameter_table(path)
    kind, dims, at = found[("ANALOG", "OFFSET")][2:]
    assert kind == 2 and dims == (n_channels,)
    struct.pack_into(f"<{n_channels}h", buf, at, *offset.tolist())
    struct.pack_into("<f", buf, found[("ANALOG", "GEN_SCALE")].data, gen_scale)
    Path(path).write_bytes(bytes(buf))
    read = ezc3d.c3d(str(path))["data"]["analogs"][0]
    np.testing.assert_allclose(read, signals, atol=1e-5 * np.abs(signals).max())
    return Path(path)


def _two_plates(first, second, yaw1=0.0, yaw2=90.0):
    """Two plates: the first under the right foot (0.1-0.6 s), heading ``yaw1``, its ORIGIN
    as the guide has it (z < 0); the second under the left (0.4-0.9 s), heading ``yaw2``,
    3 mm higher, its ORIGIN as old AMTI sheets have it (z > 0); channels not in order."""
    w1, w2 = {1: 6, 2: 6, 3: 8, 4: 6}[first], {1: 6, 2: 6, 3: 8, 4: 6}[second]
    ch1 = list(range(3, 3 + w1))
    ch2 = list(range(3 + w1, 3 + w1 + w2))[::-1]
    return [
        _plate(first, (0.3, -0.1, 0.0), yaw1, (2.0, -1.0, -40.0) if first != 3 else
               (210.0, 120.0, -45.0), (0.1, 0.6), (0.18, -0.08), (0.42, -0.12), ch1),
        _plate(second, (0.95, 0.15, 0.003), yaw2, (1.0, 3.0, 35.0) if second != 3 else
               (200.0, 140.0, 38.0), (0.4, 0.9), (0.82, 0.17), (1.05, 0.13), ch2),
    ]  # fmt: skip


FEET = {
    "RHEE": (0.15, -0.10, 0.05), "RTOE": (0.40, -0.12, 0.04), "RANK": (0.2, -0.13, 0.09),
    "LHEE": (0.80, 0.16, 0.05), "LTOE": (1.05, 0.14, 0.04), "L.Toe.Lat": (1.0, 0.18, 0.04),
    "RASI": (0.6, -0.12, 1.0),
}  # fmt: skip


def _check(plate, spec):
    """The plate's loads are the known ones (see the module docstring)."""
    f, cop, tau = _known(spec)
    scale = np.abs(f).max()
    np.testing.assert_allclose(plate.force, f, rtol=0, atol=1e-6 * scale)
    on = plate.contact
    assert on[f[:, 2] > 20.0].all() and not on[f[:, 2] < 10.0].any()
    np.testing.assert_allclose(plate.cop[on], cop[on], rtol=0, atol=1e-6)
    assert np.isnan(plate.cop[~on]).all()
    np.testing.assert_allclose(plate.free_moment[on], tau[on, None] * UP, rtol=0,
                               atol=1e-6 * scale)  # fmt: skip
    assert not plate.free_moment[~on].any()


# -- plates --------------------------------------------------------------------------------


@pytest.mark.parametrize("types", [(2, 4), (4, 2), (1, 3), (3, 1)])
def test_each_type_reads_back_its_known_loads(tmp_path, types):
    """Types 1-4, one plate as laid in the lab, the other turned 90 degrees (wrong axes from
    the corners fail it), 3 mm higher, with its ORIGIN stored the old way (z > 0: a centre of
    pressure on the wrong plane fails it); channels out of order and scaled, moments in N mm,
    a calibration matrix with cross talk (its transpose fails it)."""
    specs = _two_plates(*types)
    path = _write(tmp_path / "trial.c3d", specs, FEET)
    plates = read_plates(path)
    assert [(p.index, p.type, p.name) for p in plates] == [(1, types[0], "FP1"),
                                                           (2, types[1], "FP2")]  # fmt: skip
    for plate, spec in zip(plates, specs, strict=True):
        _check(plate, spec)
        np.testing.assert_allclose(plate.centre, spec["centre"], atol=1e-9)
        np.testing.assert_allclose(plate.time, TIME)
        assert [(plate.time[a], plate.time[b - 1]) for a, b in plate.contacts()] == [
            (plate.time[plate.contact][0], plate.time[plate.contact][-1])
        ]
    # the corners as written, the transducers' origins below the surfaces
    np.testing.assert_allclose(plates[1].corners[0], specs[1]["centre"] + [0.2, 0.3, 0.0])
    if types[0] == 2:
        # ORIGIN (2, -1, -40) mm in the plate's axes: x ours, y and z ours reversed
        np.testing.assert_allclose(plates[0].origin, specs[0]["centre"] - [0.002, 0.001, 0.04])


def test_a_y_up_lab_is_turned_to_ours(tmp_path):
    """The same loads recorded in a Y-up lab (POINT:Y_SCREEN +Y, as OpenSim's), one plate
    turned 180 degrees: read in our axes as the markers are."""
    specs = _two_plates(2, 4, yaw1=180.0, yaw2=-90.0)
    path = _write(tmp_path / "yup.c3d", specs, FEET, y_up=True)
    plates = read_plates(path)
    for plate, spec in zip(plates, specs, strict=True):
        _check(plate, spec)
    markers = read_c3d(path)
    np.testing.assert_allclose(markers.positions[0, markers.names.index("RHEE")], FEET["RHEE"],
                               atol=1e-6)  # fmt: skip
    assert read_plates(path, y_up=False)[0].force[300, 1] > 100.0  # the lab's Y kept: up


def test_units_are_their_channels_own(tmp_path):
    """Moments in N m and a type 1's centre of pressure in metres, in a millimetre lab, as
    their channels' ANALOG:UNITS say (not the lab's unit)."""
    specs = _two_plates(2, 1)
    for spec in specs:
        spec["units"] = ("m", "N.m")
    path = _write(tmp_path / "units.c3d", specs, FEET)
    for plate, spec in zip(read_plates(path), specs, strict=True):
        _check(plate, spec)


def test_types_2_and_4_agree_with_ezc3d(tmp_path):
    """ezc3d's own force plate reading of the same file (lab axes, its moments about the
    surface's centre, millimetres): the same forces, centres of pressure, moments and free
    moments."""
    import ezc3d

    specs = _two_plates(2, 4, yaw1=180.0)
    path = _write(tmp_path / "trial.c3d", specs, FEET)
    ours = read_plates(path)
    theirs = ezc3d.c3d(str(path), extract_forceplat_data=True)["data"]["platform"]
    for p, e in zip(ours, theirs, strict=True):
        on = p.contact
        np.testing.assert_allclose(p.force, e["force"].T, rtol=0, atol=1e-9 * PEAK)
        np.testing.assert_allclose(p.cop[on], e["center_of_pressure"].T[on] * 1e-3, atol=1e-9)
        np.testing.assert_allclose(p.free_moment[on], e["Tz"].T[on] * 1e-3, atol=1e-9 * PEAK)
        moment = np.cross(p.cop[on] - p.centre, p.force[on]) + p.free_moment[on]
        np.testing.assert_allclose(moment, e["moment"].T[on] * 1e-3, atol=1e-9 * PEAK)
        np.testing.assert_allclose(p.corners, e["corners"].T * 1e-3)


def test_contact_has_hysteresis(tmp_path):
    """A force that rises to 15 N (under the 20 N threshold: no contact), then above 20 N,
    dips to 12 N (over the 10 N release: still in contact) and falls under 10 N: one contact,
    from the first sample over 20 N to the last over 10 N."""
    spec = _plate(2, (0.3, 0.0, 0.0), 0.0, (0, 0, -40), (0.1, 0.6), (0.2, 0), (0.4, 0),
                  range(3, 9))  # fmt: skip
    fz = np.interp(TIME, [0, 0.1, 0.15, 0.2, 0.3, 0.35, 0.4, 0.5, 0.6, 1.0],
                   [0, 15, 15, 5, 60, 12, 60, 60, 0, 0])  # fmt: skip

    def plain(signals):  # a vertical force at the surface's centre, nothing else
        signals[2:8] = 0.0
        signals[4] = -fz  # upward on the subject: the plate's -z

    path = _write(tmp_path / "h.c3d", [spec], edit=plain)
    (plate,) = read_plates(path)
    np.testing.assert_allclose(plate.force[:, 2], fz, atol=1e-4)
    (a, b), = plate.contacts()  # fmt: skip
    assert a == np.flatnonzero(fz > 20.0)[0] and b - 1 == np.flatnonzero(fz > 10.0)[-1]
    assert read_plates(path, threshold=70.0)[0].contacts() == []
    np.testing.assert_allclose(plate.cop[a:b], np.tile([0.3, 0.0, 0.0], (b - a, 1)), atol=1e-9)


def test_an_unloaded_plate_pulling_down_is_no_contact(tmp_path):
    """A plate's unloaded offset that pulls the subject down (-25 N, as OpenSim's walking5.c3d
    reads without zeroing: |Fz| over the threshold) is no contact; the step on it is one. A
    file holding the force on the plate (every sign turned) is read with its contact and a
    warning; a plate never stepped on whose offset points down is neither."""
    spec = _plate(2, (0.3, 0.0, 0.0), 0.0, (0, 0, -40), (0.3, 0.6), (0.2, 0), (0.4, 0),
                  range(3, 9))  # fmt: skip
    fz = np.interp(TIME, [0, 0.3, 0.45, 0.6, 1.0], [-25, -25, 600, -25, -25])
    step = fz > 20.0

    def offset(signals, sign=1.0, force=fz):
        signals[2:8] = 0.0
        signals[4] = -sign * force  # upward on the subject: the plate's -z

    (plate,) = read_plates(_write(tmp_path / "o.c3d", [spec], edit=offset))
    np.testing.assert_allclose(plate.force[:, 2], fz, atol=1e-4)
    (a, b), = plate.contacts()  # fmt: skip
    assert a == np.flatnonzero(step)[0] and b - 1 == np.flatnonzero(fz > 10.0)[-1]
    path = _write(tmp_path / "d.c3d", [spec], edit=lambda s: offset(s, -1.0))
    with pytest.warns(PlateWarning, match="points down"):
        (down,) = read_plates(path)
    assert down.contacts() == [(a, b)]
    idle = _write(tmp_path / "i.c3d", [spec], edit=lambda s: offset(s, 1.0, np.full_like(fz, -25)))
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlateWarning)
        assert read_plates(idle)[0].contacts() == []


# -- feet ----------------------------------------------------------------------------------


def test_foot_markers_by_name():
    """Plug-in Gait, OpenSim, ISB/CAST (Qualisys) and BTS names of the feet's markers, and
    names that are not a foot's (a calf, a shank, a knee's FME, no side, two sides)."""
    names = ["LHEE", "RHEE", "LTOE", "RTOE", "LANK", "R_MT5", "L.Heel", "R.Toe.Tip", "heel_r",
             "toe_l", "LeftHeel", "Bob:RHEE", "HeelR", "RMed_Mal", "L_FCC", "L_FM1", "R_FAL",
             "R_TAM", "l heel", "r met",
             "RCALF", "R_SHANK", "LateralMalleolus", "LKNE", "L_FME", "RASI", "HEEL", "C7",
             "L_heel_r"]  # fmt: skip
    feet = foot_markers(names)
    assert [names[i] for i in feet["left"]] == ["LHEE", "LTOE", "LANK", "L.Heel", "toe_l",
                                                "LeftHeel", "L_FCC", "L_FM1", "l heel"]  # fmt: skip
    assert [names[i] for i in feet["right"]] == ["RHEE", "RTOE", "R_MT5", "R.Toe.Tip", "heel_r",
                                                 "Bob:RHEE", "HeelR", "RMed_Mal", "R_FAL",
                                                 "R_TAM", "r met"]  # fmt: skip


def test_plates_go_to_the_feet_their_markers_show(tmp_path):
    """The right foot's markers over the first plate, the left's over the second: each
    contact is that foot's load, zero outside it; with the names swapped, the other foot's."""
    specs = _two_plates(4, 2)
    path = _write(tmp_path / "trial.c3d", specs, FEET)
    plates, loads = c3d_loads(path)
    assert [(x.body, x.name) for x in loads] == [("left", "FP2"), ("right", "FP1")]
    for load, plate in ((loads[0], plates[1]), (loads[1], plates[0])):
        on = plate.contact
        np.testing.assert_array_equal(load.time, plate.time)
        np.testing.assert_allclose(load.force[on], plate.force[on])
        np.testing.assert_allclose(load.point[on], plate.cop[on])
        np.testing.assert_allclose(load.torque[on], plate.free_moment[on])
        assert not load.force[~on].any() and not load.point[~on].any()
    swapped = {("L" + k[1:] if k[0] == "R" else "R" + k[1:]): v for k, v in FEET.items()}
    path = _write(tmp_path / "swapped.c3d", specs, swapped)
    assert [(x.body, x.name) for x in c3d_loads(path)[1]] == [("left", "FP1"), ("right", "FP2")]
    # named by hand, whatever the markers say
    sides = {1: "left", 2: "left"}
    assert [(x.body, x.name) for x in c3d_loads(path, sides=sides)[1]] == [("left", "FP1+FP2")]
    with pytest.raises(MotionFileError, match="plate 1: its side must be left or right"):
        plate_loads(plates, read_c3d(path), {1: "middle"})
    assert plate_loads([], read_c3d(path)) == []


def test_one_foot_on_two_plates_adds_their_wrenches(tmp_path):
    """Both plates given to one foot: where their contacts overlap (0.4-0.6 s), the load is
    their sum: its force the sum, its moment about the origin the sum of theirs."""
    specs = _two_plates(2, 2)
    path = _write(tmp_path / "trial.c3d", specs, FEET)
    plates, (load,) = c3d_loads(path, sides={1: "right", 2: "right"})
    both = plates[0].contact & plates[1].contact
    assert both.sum() > 100
    want = sum(np.hstack([p.force[both], np.cross(p.cop[both], p.force[both])
                          + p.free_moment[both]]) for p in plates)  # fmt: skip
    np.testing.assert_allclose(load.wrench[both], want, atol=1e-9 * PEAK)
    assert np.allclose(load.torque[both, :2], 0.0) and (load.point[both, 2] > 0).all()


def test_unclear_feet_warn_and_give_nothing(tmp_path):
    """Both feet's markers as near a plate's centre of pressure: a warning naming the plate
    and its times, and that contact goes to no foot; no foot markers at all: a warning, no
    loads; a foot far from every plate: none."""
    specs = _two_plates(2, 2)
    near = dict(FEET)
    near["LHEE"], near["LTOE"] = (0.16, -0.09, 0.05), (0.41, -0.11, 0.04)
    path = _write(tmp_path / "near.c3d", specs, near)
    with pytest.warns(PlateWarning, match=r"force plate 1 \(FP1\), contact 0\.1\d\d-0\.5\d\d s"):
        plates, loads = c3d_loads(path)
    assert [(x.body, x.name) for x in loads] == [("left", "FP2")]
    path = _write(tmp_path / "none.c3d", specs, {"A": np.zeros(3), "RASI": np.ones(3)})
    with pytest.warns(PlateWarning, match="no foot markers"):
        assert c3d_loads(path)[1] == []
    far = {"RHEE": (5.0, 5.0, 0.0), "LHEE": (-5.0, 5.0, 0.0)}
    path = _write(tmp_path / "far.c3d", specs, far)
    with pytest.warns(PlateWarning, match="no foot within 0.3 m"):
        assert c3d_loads(path)[1] == []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sides = {1: "left", 2: "right"}
        assert [s for *_, s in assign_contacts(plates, read_c3d(path), sides)] == ["left", "right"]


# -- the commands --------------------------------------------------------------------------


def test_humanoid_loads_writes_what_reads_back(tmp_path, capsys, monkeypatch):
    """``humanoid loads trial.c3d -o grf.mot``: OpenSim's .mot and its ExternalLoads .xml;
    read back, the feet's loads as the plates gave them (to rounding: full precision)."""
    from humanoid.cli import main

    monkeypatch.chdir(tmp_path)  # (the default output is written here)

    specs = _two_plates(2, 4)
    events = [(0.1, "Right", "Foot Strike"), (0.4, "Left", "Foot Strike")]
    path = _write(tmp_path / "trial.c3d", specs, FEET, events=events)
    out = tmp_path / "out" / "grf.mot"
    assert main(["loads", str(path), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "FP1          contact 0.1" in text and ": right foot" in text
    assert "events       2: Right Foot Strike 0.100 s, Left Foot Strike 0.400 s" in text
    assert out.with_suffix(".xml").exists()
    back = read_loads(out)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, want = c3d_loads(path)
    assert [x.body for x in back] == [x.body for x in want] == ["left", "right"]
    for a, b in zip(back, want, strict=True):
        np.testing.assert_allclose(a.time, b.time, rtol=0, atol=1e-12)
        for key in ("force", "point", "torque"):
            np.testing.assert_allclose(getattr(a, key), getattr(b, key), rtol=0, atol=1e-6)
    # no foot to give a plate to: exit 2 and why
    path = _write(tmp_path / "bare.c3d", specs, {"A": np.zeros(3)})
    assert main(["loads", str(path), "-o", str(tmp_path / "x.mot")]) == 2
    assert "--plate-side" in capsys.readouterr().err
    assert main(["loads", str(path), "-o", str(tmp_path / "x.mot"), "--plate-side", "1=right",
                 "--plate-side", "2=left"]) == 0  # fmt: skip
    assert main(["loads", str(path), "--plate-side", "one=left"]) == 2
    assert main(["loads", str(path), "--plate-side", "1=right"]) == 0
    assert [x.body for x in read_loads(tmp_path / "bare_grf.mot")] == ["right"]


def test_humanoid_id_takes_a_c3d_as_its_loads(tmp_path, capsys):
    """``humanoid id motion.mot --loads trial.c3d``: the plates, given to the feet by the
    trial's markers, are the loads inverse dynamics applies."""
    from humanoid.cli import main
    from humanoid.motion.commands import read_loads_file
    from humanoid.motion.coordinates import coordinates_table
    from humanoid.motion.storage import write_storage

    path = _write(tmp_path / "trial.c3d", _two_plates(2, 4), FEET)
    assert [(x.body, x.name) for x in read_loads_file(path)] == [("left", "FP2"),
                                                                 ("right", "FP1")]  # fmt: skip
    with pytest.raises(HumanoidError, match="--loads-side"):
        read_loads_file(path, {"x": "left"})
    h = get_model("male", "quaternion")
    t = np.arange(0, 1.0, 0.01)
    q = np.tile(h.standing_configuration(), (len(t), 1))
    motion = write_storage(tmp_path / "stand.mot", coordinates_table(h, t, q, "rajagopal"))
    args = ["id", str(motion), "--loads", str(path), "-o", str(tmp_path / "id.sto")]
    assert main(args) == 0
    assert "loads        left (FP2), right (FP1)" in capsys.readouterr().out


# -- bad files and events ------------------------------------------------------------------


def _bad(tmp_path, name, patch, specs=None):
    return _write(tmp_path / f"{name}.c3d", specs or _two_plates(2, 4), FEET, patch=patch)


def test_bad_files_name_the_file_and_the_parameter(tmp_path):
    def unused(c):
        c["parameters"]["FORCE_PLATFORM"]["USED"]["value"] = np.array([0])

    def no_cal(c):
        c["parameters"]["FORCE_PLATFORM"]["CAL_MATRIX"]["value"] = np.zeros(0)

    def past(c):
        c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"][3, 1] = 99

    def type6(c):
        c["parameters"]["FORCE_PLATFORM"]["TYPE"]["value"] = np.array([2, 6])

    def corners(c):
        c["parameters"]["FORCE_PLATFORM"]["CORNERS"]["value"] = np.zeros((3, 3, 2))

    def short(c):
        c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"] = np.ones((4, 2), dtype=int)

    cases = [
        (unused, r"FORCE_PLATFORM:USED is 0"),
        (no_cal, r"plate 2 is type 4 but FORCE_PLATFORM:CAL_MATRIX is missing"),
        (past, r"FORCE_PLATFORM:CHANNEL of plate 2 names analog channel\(s\) \[99\]"),
        (type6, r"FORCE_PLATFORM:TYPE of plate 2 is 6"),
        (corners, r"FORCE_PLATFORM:CORNERS must be 3 x 4 x 2"),
        (short, r"FORCE_PLATFORM:CHANNEL has 4 channels per plate"),
    ]
    for k, (patch, message) in enumerate(cases):
        path = _bad(tmp_path, f"bad{k}", patch)
        with pytest.raises(MotionFileError, match=message) as err:
            read_plates(path)
        assert str(path) in str(err.value)
    with pytest.raises(MotionFileError, match="not found"):
        read_plates(tmp_path / "none.c3d")

    def flat(c):  # some writers fill an unused plate's parameters with garbage
        c["parameters"]["FORCE_PLATFORM"]["CORNERS"]["value"][:, :, 0] = 0.0

    with pytest.warns(PlateWarning, match="CORNERS of plate 1 do not span a rectangle"):
        assert [p.name for p in read_plates(_bad(tmp_path, "flat", flat))] == ["FP2"]

    def flats(c):
        c["parameters"]["FORCE_PLATFORM"]["CORNERS"]["value"][:] = 1e9

    with pytest.warns(PlateWarning), pytest.raises(MotionFileError, match="can be placed"):
        read_plates(_bad(tmp_path, "flats", flats))

    def down(signals):  # a file holding the force on the plate: read as recorded, said so
        signals[2:8] *= -1.0

    path = _write(tmp_path / "down.c3d", _two_plates(2, 4), FEET, edit=down)
    with pytest.warns(PlateWarning, match="plate 1's vertical force points down"):
        assert read_plates(path)[0].force[300, 2] < -100.0

    def poly(c):  # Kistler's centre of pressure correction: not applied, said so
        c.add_parameter("FORCE_PLATFORM", "FPCOPPOLY", np.linspace(0.0, 1e-6, 24))

    with pytest.warns(PlateWarning, match="FPCOPPOLY .* not applied to plate 1"):
        read_plates(_bad(tmp_path, "poly", poly, _two_plates(3, 2)))
    with pytest.raises(MotionFileError, match="threshold"):
        read_plates(_bad(tmp_path, "ok", None), threshold=0.0)


def test_a_c3d_without_force_platform_group(tmp_path):
    """A file of markers with no FORCE_PLATFORM group (ezc3d writes one, so its name is
    patched away in the file; ezc3d reads it back with USED 0): no force plates, said so."""
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([RATE])
    c["parameters"]["POINT"]["LABELS"]["value"] = ["A"]
    c["data"]["points"] = np.ones((4, 1, 3))
    path = tmp_path / "markers.c3d"
    c.write(str(path))
    buf = Path(path).read_bytes().replace(b"FORCE_PLATFORM", b"FORCE_PLATFORX")
    path.write_bytes(buf)
    with pytest.raises(MotionFileError, match=f"{path}: FORCE_PLATFORM:USED is 0: no force"):
        read_plates(path)
    assert read_events(path) == []


def test_events_are_read_when_present(tmp_path):
    events = [(1.25, "Left", "Foot Strike"), (0.5, "Right", "Foot Off"),
              (61.0, "General", "Start")]  # fmt: skip
    path = _write(tmp_path / "e.c3d", _two_plates(2, 4), FEET, events=events)
    got = read_events(path)
    assert [(c, label) for _, c, label in got] == [("Right", "Foot Off"), ("Left", "Foot Strike"),
                                                   ("General", "Start")]  # fmt: skip
    np.testing.assert_allclose([t for t, _, _ in got], [0.5, 1.25, 61.0], atol=1e-6)
    assert read_events(_write(tmp_path / "none.c3d", _two_plates(2, 4), FEET)) == []

    def bare(c):  # labels, no contexts (as a Qualisys file has them)
        del c["parameters"]["EVENT"]["CONTEXTS"]

    path = _write(tmp_path / "bare.c3d", _two_plates(2, 4), FEET, events=events, patch=bare)
    assert [(c, label) for _, c, label in read_events(path)] == [("", "Foot Off"),
                                                                 ("", "Foot Strike"),
                                                                 ("", "Start")]  # fmt: skip
