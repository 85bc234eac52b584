"""Named marker sets (humanoid.motion.marker_sets): Plug-in Gait, walking5's cluster set, and
the choice of a set by a trial's labels.

- walking5.c3d's labels call for the cluster set (34 of its 40 labels; its 6 Nexus joint
  centres named in a warning), a Plug-in Gait trial's for plugin-gait, gait2354's for the
  default; a ``Subject:`` prefix changes nothing.
- walking5 fitted on the unscaled adult_male (every 10th of the frames where half its markers
  are seen): the mean RMS marker residual per frame was measured 25.6 mm (the pelvis's and the
  epicondyles' 40-60 mm each, the clusters' 4-12 mm); the bound is 30 mm. The same labels
  with left and right swapped, or a malleolus put on the thigh, fail it.
- Plug-in Gait markers made by the body itself (its own set, moved by a known motion) are
  fitted back (1 mm mean per frame, 5 mm each: measured 0.6 and 3.0); swapped sides are not.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import humanoid as hm
from humanoid.data import TRIALS
from humanoid.errors import HumanoidError
from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.marker_sets import (
    MARKER_SETS,
    MarkerSetWarning,
    choose_marker_set,
    resolve_marker_set,
    strip_prefix,
)
from humanoid.motion.markers import (
    MarkerTrajectories,
    default_markers,
    marker_positions,
    read_c3d,
    read_trc,
    write_trc,
)

C3D = TRIALS / "walking5.c3d"
BOUND = 0.030  # [m] walking5's mean RMS residual per frame (measured 25.6 mm)
PIG_LEGS = ("ASI", "PSI", "THI", "KNE", "TIB", "ANK", "HEE", "TOE")


@pytest.fixture(scope="module")
def body():
    return hm.load("adult_male")


@pytest.fixture(scope="module")
def walking5():
    return read_c3d(C3D)


def _swap(name: str) -> str:
    return {"L": "R", "R": "L"}.get(name[:1], name[:1]) + name[1:]


def _renamed(m: MarkerTrajectories, names) -> MarkerTrajectories:
    return MarkerTrajectories(m.time, list(names), m.positions, m.source)


def _fit(body, markers, marker_set, register=True, step=10):
    """The mean RMS residual per frame [m] and each marker's RMS of every ``step``-th frame."""
    part = MarkerTrajectories(markers.time[::step], markers.names, markers.positions[::step])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (range limits, unseen arms: said elsewhere)
        r = inverse_kinematics(body, part, marker_set, register=register)
    return float(np.nanmean(r.frame_rms())), r.marker_rms()


def test_each_set_is_chosen_by_its_labels(walking5):
    assert choose_marker_set(walking5.names) == ("clusters", 34)
    pig = MARKER_SETS["plugin-gait"].names
    assert choose_marker_set(pig)[0] == "plugin-gait"
    assert choose_marker_set([f"Subject:{n}" for n in pig])[0] == "plugin-gait"
    assert choose_marker_set(read_trc(TRIALS / "subject01_walk1.trc").names)[0] == "gait2354"
    assert choose_marker_set(["nothing", "else"]) == ("gait2354", 0)  # the default on a tie
    # the shipped sets' names are the CLI's
    from humanoid import cli

    assert cli.MARKER_SETS == tuple(MARKER_SETS)


def test_plugin_gait_markers_sit_where_the_guide_puts_them(body):
    """Every PiG marker on its segment, in the guide's order from head to heel standing, its
    asymmetric markers on one side or at different heights."""
    ms = default_markers(body, MARKER_SETS["plugin-gait"].file)
    assert len(MARKER_SETS["plugin-gait"].names) == 40
    for s, side in (("L", "left"), ("R", "right")):
        frames = {n: ms[s + n].frame for n in PIG_LEGS}
        assert frames == {"ASI": "pelvis", "PSI": "pelvis", "THI": f"{side}_thigh",
                          "KNE": f"{side}_thigh", "TIB": f"{side}_shank",
                          "ANK": f"{side}_shank", "HEE": f"{side}_foot",
                          "TOE": f"{side}_foot"}  # fmt: skip
        for n, seg in (("ELB", "upper_arm"), ("WRA", "forearm"), ("FIN", "hand")):
            assert ms[s + n].frame == f"{side}_{seg}"
        assert not ms[s + "THI"].anatomical and not ms[s + "TIB"].anatomical
        assert ms[s + "KNE"].anatomical and ms[s + "ANK"].anatomical
    assert "RBAK" in ms and "LBAK" not in ms
    names = ["LFHD", "C7", "LSHO", "CLAV", "STRN", "LASI", "LTHI", "LKNE", "LTIB", "LANK"]
    z = marker_positions(body, body.standing_configuration(), ms, names)[0][:, 2]
    assert np.all(np.diff(z) < 0), dict(zip(names, z.round(3), strict=True))
    up = marker_positions(body, body.standing_configuration(), ms, ["LUPA", "RUPA", "LFRM",
                                                                     "RFRM"])[0][:, 2]  # fmt: skip
    assert up[0] > up[1] + 0.05 and up[3] > up[2] + 0.05  # PiG's asymmetry
    y = marker_positions(body, body.standing_configuration(), ms, ["LASI", "RASI"])[0][:, 1]
    assert y[0] > 0.1 and y[1] < -0.1  # left is +y


def test_walking5_fits_its_cluster_set(body, walking5):
    with pytest.warns(MarkerSetWarning, match="LAJC, LHJC, LKJC, RAJC, RHJC, RKJC"):
        chosen = resolve_marker_set(body, walking5)
    assert chosen.name == "clusters" and chosen.register and not chosen.prefix
    assert len(chosen.used) == 34 and len(chosen.ignored) == 6
    markers, before, after = chosen.cropped()
    assert (before, after) == (410, 113)  # 1.640-3.956 s: half the 34 markers seen
    mean, rms = _fit(body, markers, chosen.markers)
    assert mean < BOUND, mean
    clusters = [rms[f"{s}{c}{k}"] for s in "LR" for c in ("TH", "TB") for k in "123"]
    assert max(clusters) < 0.02, clusters


def test_walking5_with_sides_swapped_or_a_marker_misplaced_fails_the_bound(body, walking5):
    with pytest.warns(MarkerSetWarning):
        chosen = resolve_marker_set(body, walking5)
    markers = chosen.cropped()[0]
    swapped = _renamed(markers, [_swap(n) for n in markers.names])
    assert _fit(body, swapped, chosen.markers)[0] > 1.5 * BOUND
    wrong = dict(chosen.markers)
    wrong["RLMAL"] = default_markers(body, MARKER_SETS["clusters"].file)["RLFC"]  # on the thigh
    mean, rms = _fit(body, markers, wrong)
    assert rms["RLMAL"] > 0.1, rms["RLMAL"]


def _pig_trial(body, prefix=""):
    """Plug-in Gait markers made by the body's own set over a knee bend and a step, 20 frames."""
    ms = default_markers(body, MARKER_SETS["plugin-gait"].file)
    names = list(MARKER_SETS["plugin-gait"].names)
    q0 = body.standing_configuration()
    model = body.model
    knee = model.joints[model.getJointId("left_knee")].idx_q
    hip = model.joints[model.getJointId("right_hip")].idx_q
    q = np.repeat(q0[None], 20, axis=0)
    s = np.linspace(0.0, 1.0, 20)
    q[:, 0] += 0.5 * s
    q[:, knee] += 0.8 * s
    q[:, hip] += 0.3 * s
    pos = marker_positions(body, q, ms, names)
    return MarkerTrajectories(s / 100.0, [prefix + n for n in names], pos, "pig")


def test_plugin_gait_trial_with_a_subject_prefix(body):
    trial = _pig_trial(body, "Subject:")
    with warnings.catch_warnings():
        warnings.simplefilter("error", MarkerSetWarning)  # every label is in the set
        chosen = resolve_marker_set(body, trial)
    assert chosen.name == "plugin-gait" and chosen.prefix == "Subject"
    assert chosen.trajectories.names == list(MARKER_SETS["plugin-gait"].names)
    assert "'Subject'" in chosen.describe()
    mean, rms = _fit(body, chosen.trajectories, chosen.markers, register=False, step=1)
    assert mean < 1e-3 and max(rms.values()) < 5e-3, mean  # (the pull to standing)
    swapped = _renamed(chosen.trajectories, [_swap(n) for n in chosen.trajectories.names])
    assert _fit(body, swapped, chosen.markers, register=False, step=1)[0] > 0.02


def test_unknown_labels_are_named_and_a_set_can_be_asked_for(body, walking5):
    trial = _pig_trial(body)
    extra = MarkerTrajectories(trial.time, trial.names + ["LHJC", "CentreOfMass"],
                               np.concatenate([trial.positions, trial.positions[:, :2]], axis=1),
                               "pig")  # fmt: skip
    with pytest.warns(MarkerSetWarning, match=r"2 labels .* LHJC, CentreOfMass \(LHJC: a "):
        chosen = resolve_marker_set(body, extra)
    assert chosen.ignored == ("LHJC", "CentreOfMass")
    # asked for by name: walking5 on Plug-in Gait has its pelvis and trunk only
    with pytest.warns(MarkerSetWarning, match="LTH3"):
        pig = resolve_marker_set(body, walking5, "plugin-gait")
    assert sorted(pig.used) == sorted(["C7", "CLAV", "LASI", "LPSI", "RASI", "RPSI", "STRN",
                                       "T10"])  # fmt: skip
    with pytest.raises(HumanoidError, match="gait2354, plugin-gait, clusters"):
        resolve_marker_set(body, walking5, "vicon")
    with pytest.raises(HumanoidError, match="none of its labels .* is in the marker set gait2354"):
        resolve_marker_set(body, walking5, "gait2354")
    with pytest.raises(HumanoidError, match="2 subjects \\(A, B\\)"):
        strip_prefix(["A:LASI", "B:LASI"])
    assert strip_prefix(["A:LASI", "RASI"]) == (["LASI", "RASI"], "A")


def test_landmark_file_as_marker_set(body, walking5, tmp_path):
    """A lab's own landmark file (as the shipped ones) by path; a bad one named."""
    path = tmp_path / "mine.toml"
    path.write_text(MARKER_SETS["clusters"].file.read_text().replace("register = true", ""))
    with pytest.warns(MarkerSetWarning):
        chosen = resolve_marker_set(body, walking5, str(path))
    assert chosen.name == str(path) and not chosen.register and len(chosen.used) == 34
    bad = tmp_path / "bad.toml"
    bad.write_text('[landmarks."X"]\nsides = "both"\nframe = "thigh"\nfrom = "knee"\n'
                   "offset = [0, 0, 0]\n")  # fmt: skip
    with pytest.raises(HumanoidError, match="landmarks.X needs .* sides true, false"):
        resolve_marker_set(body, walking5, str(bad))


def test_ik_command_says_which_set(body, tmp_path, capsys):
    from humanoid.cli import main

    trc = write_trc(tmp_path / "pig.trc", _pig_trial(body, "Subject:"))
    assert main(["ik", str(trc), "-o", str(tmp_path / "ik.mot"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "marker set   plugin-gait (chosen by the trial's labels: 40 of the trial's 40" in out
    assert "markers      40 of 40 in the set" in out
    assert main(["ik", str(trc), "--marker-set", "pig", "-o", str(tmp_path / "x.mot")]) != 0
    assert "marker set 'pig': one of gait2354, plugin-gait, clusters" in capsys.readouterr().err
