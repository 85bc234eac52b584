"""The person's walk of bodies other than the default two: the 1.50 m, 45 kg female and the
1.95 m, 100 kg male, each walking the free-speed cycle shipped for it (``make gaits`` solves
them) on the rigid ground, measured by the gait analysis."""

import numpy as np
import pytest

import humanoid as hm
from humanoid.optimal.cycle import stored_gait
from humanoid.walking.gait import analyse
from humanoid.walking.norms import norms
from humanoid.walking.person import CycleReference, walk_cycle

SIZES = {"small_female": (1.50, 45.0, "female"), "tall_male": (1.95, 100.0, "male")}
STEPS = 10


@pytest.mark.parametrize("name", list(SIZES))
def test_a_small_and_a_tall_body_walk_their_shipped_cycles_as_people(name):
    """Their speeds, step lengths and cadences are their legs' (the cycle's speed: the same
    dimensionless speed as the default bodies'); stance and double support a person's at that
    speed (Schwartz's mean +- 2 SD), the forces, the ankle's peaks and the curves in the adults'
    bands (before the tracking objective followed the knee's moment, the tall body's knee
    moment was inside its band for 67 % of the cycle and the small body's push-off power
    peaked at 4.58 W/kg)."""
    h = hm.load(hm.build_urdf(hm.BodyParameters(*SIZES[name])))
    g = stored_gait(h)
    assert g is not None, f"no cycle shipped for the {name} body"
    w = walk_cycle(h, g, STEPS)
    assert w.completed, w.trajectory.metadata.get("message")
    assert np.abs(w.trajectory.tau[:, :6]).max() == 0.0
    a = analyse(h, w)
    s = a.summary
    assert abs(s["speed"] - g.speed) < 0.03, s
    # the cycle's own cadence, its legs' (the small body's 119 steps/min, at the adults' 120;
    # walked with the QP every 4 ms, 121.6: 1.5 % ahead of its cycle, 0.2 % at every step)
    assert abs(s["cadence"] / (120.0 / CycleReference(g).period) - 1.0) < 0.03, s
    for ours, event in (("stance", "ipsilateral_foot_off"), ("double_support", "double_support")):
        mean, sd = norms().event(event, a.dimensionless_speed)
        assert abs(s[ours] - mean) <= 2 * sd, (ours, s[ours], mean, sd)
    bands = {
        "grf_first_peak": (1.05, 1.30), "grf_second_peak": (1.05, 1.30),
        "grf_trough": (0.60, 0.85), "braking": (0.15, 0.25), "propulsion": (0.15, 0.25),
        "ankle_moment_peak": (1.2, 1.6), "ankle_power_peak": (2.5, 4.5),
        **{f"{c}_in_band": (0.8, 1.0) for c in ("hip_flexion", "knee_flexion",
                                                "ankle_dorsiflexion")},
        **{f"{c}_in_band": (0.7, 1.0) for c in ("hip_extension_moment", "knee_extension_moment",
                                                "ankle_plantarflexion_moment")},
    }  # fmt: skip
    outside = {k for k, (lo, hi) in bands.items() if not lo <= s[k] <= hi}
    assert not outside, {k: s[k] for k in outside}
    assert s["heel_to_toe"] == 1.0 and s["slip"] < 3e-3, s
