"""The planted-bug (mutation) measurement: one-line bugs, each planted alone in the package's
source, the tests that should catch it run, the bug *killed* if any of them fails (or errors,
or runs out of time) and *survived* otherwise.

The bugs are planted in a temporary copy of the repository's files (``git ls-files``, new ones
too), never in the working tree: each is written, its tests run with the copy first on the
path, and the file put back before the next. The selected tests are first run once on the
unmutated copy: a selection that fails there makes the measurement invalid (the script stops).
Results cached by a run (a fitted walking cycle the mutated fitting code keys afresh) go to a
temporary ``HUMANOID_CACHE``, not the user's.

    python scripts/mutation.py                  # all: docs/bench/mutation.md and .json
    python scripts/mutation.py --only P01 IK1   # a few: results/mutation.md and .json
    python scripts/mutation.py --only P01 --update  # run again, merged into docs/bench/mutation.*
    python scripts/mutation.py --list           # the table, nothing run

The table (:data:`MUTATIONS`) is checked by tests/test_mutation_table.py: every old text
occurs exactly once in its file, and every test file it names exists.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TIMEOUT = 600.0  # [s] per mutation; a run out of time counts as killed (reported apart)


@dataclass(frozen=True)
class Mutation:
    """One planted bug: in ``file`` (under humanoid/) the text ``old`` (it must occur exactly
    once) becomes ``new``; ``tests`` (files or pytest node ids under tests/) should catch it."""

    id: str
    file: str
    old: str
    new: str
    tests: tuple[str, ...]
    bug: str


def M(id_, file, old, new, tests, bug) -> Mutation:
    tests = (tests,) if isinstance(tests, str) else tuple(tests)
    return Mutation(id_, file, old, new, tests, bug)


P = "tests/test_planted.py"
TM = "tests/test_motion.py::"
# the quick tests of the files whose whole run walks or simulates for minutes
GAIT = tuple("tests/test_gait.py::test_" + t for t in (
    "events_and_spatiotemporal_values_of_a_walk_drawn_by_hand",
    "a_stance_the_record_ends_in_is_not_analysed",
    "the_pelvis_and_the_anterior_force_are_measured_along_the_progression",
    "a_peak_is_each_sides_averaged_not_the_peak_of_the_sides_mean_curve",
    "the_gait_report_draws_the_curves_over_the_norms"))  # fmt: skip
GROUND = tuple("tests/test_ground.py::test_" + t for t in (
    "a_sliding_box_stops_at_the_analytic_distance",
    "a_box_on_a_slope_sticks_below_atan_mu_and_slides_above",
    "a_falling_body_comes_to_rest_on_the_floor",
    "ground_impulses_change_momentum_by_exactly_their_sum"))  # fmt: skip
RANGES = tuple("tests/test_ground.py::test_" + t for t in (
    "range_rows_match_finite_differences", "range_certificates_skip_only_what_is_clear",
    "joint_ranges_hold_in_the_fall"))  # fmt: skip
TS = "tests/test_simulate.py::test_"
FORCES = "tests/test_forces.py::test_"
TV = "tests/test_viewer.py::test_"
C3D = ("tests/test_bad_input.py::test_a_truncated_c3d_is_refused_before_ezc3d_reads_it",
       "tests/test_bad_input.py::test_a_c3d_parameter_of_too_many_dimensions_is_refused",
       "tests/test_bad_input.py::test_an_empty_c3d_unit_is_a_motion_file_error",
       "tests/test_c3d_plates.py::test_types_2_and_4_agree_with_ezc3d",
       "tests/test_c3d_plates.py::test_bad_files_name_the_file_and_the_parameter")  # fmt: skip
SCALE = tuple("tests/test_scale.py::test_" + t for t in (
    "scaling_recovers_the_subject", "each_side_is_measured_on_its_own",
    "a_segment_without_markers_keeps_the_stature_scaling",
    "a_uniformly_scaled_subjects_markers_are_carried_exactly"))  # fmt: skip

MUTATIONS: tuple[Mutation, ...] = (
    # --- the ten of the last review (six survivors, four caught only by a whole walk) ---
    M(
        "P01",
        "motion/inverse_dynamics.py",
        "res_f[i], res_m[i] = R @ tau[i, :3], R @ tau[i, 3:6]",
        "res_f[i], res_m[i] = tau[i, :3], tau[i, 3:6]",
        (P, TM + "test_inverse_dynamics_of_a_standing_body_is_its_weight"),
        "ID's root residuals left in the pelvis' axes, reported as world",
    ),
    M(
        "P02",
        "motion/coordinates.py",
        "(table.in_degrees is not False)",
        "(table.in_degrees is True)",
        (P, TM + "test_coordinates_round_trip", TM + "test_coordinates_mean_what_opensim_means"),
        "a .mot without an inDegrees line read as radians",
    ),
    M(
        "P03",
        "motion/ik.py",
        "b = J.T @ (w * r) - reg * (De.T @ e)",
        "b = J.T @ r - reg * (De.T @ e)",
        (P,),
        "IK's marker weights dropped from the gradient (J' r, not J' W r)",
    ),
    M(
        "P04",
        "control/tasks.py",
        "cop = c[:2] - ddc[:2] * c[2] / gz",
        "cop = c[:2] + ddc[:2] * c[2] / gz",
        (P, "tests/test_control.py"),
        "the tracking CoM task's centre of pressure with the wrong sign",
    ),
    M(
        "P05",
        "walking/gait.py",
        "ang = _at(angles[s], tk, tt)",
        "ang = _at(angles[s], tk, tt + (tk[1] - tk[0]))",
        (P, *GAIT),
        "the gait cycle's curves sampled one sample off",
    ),
    M(
        "P06",
        "study/store.py",
        'r["status"] not in ("failed", "error")',
        'r["status"] in ("failed", "error")',
        (P, "tests/test_study.py::test_the_same_study_again_runs_nothing"),
        "--retry-failed reruns the good runs and keeps the failed ones",
    ),
    M(
        "P07",
        "constraints/solve.py",
        "gamma -= 2.0 * baumgarte.alpha * (J @ v)",
        "gamma -= baumgarte.alpha * (J @ v)",
        (P, "tests/test_constraints.py"),
        "Baumgarte's velocity factor 2 alpha -> alpha",
    ),
    M(
        "P08",
        "contacts.py",
        "self.sole = h.sole_id(spec.foot)",
        'self.sole = h.sole_id("right" if spec.foot == "left" else "left")',
        (P,),
        "the left and right soles swapped in ContactState",
    ),
    M(
        "P09",
        "control/qp.py",
        "m = mu / np.sqrt(2.0)",
        "m = mu",
        (P, "tests/test_control.py"),
        "the walking QP's friction pyramid at mu, not mu / sqrt 2 (outside the cone)",
    ),
    M(
        "P10",
        "constraints/ground.py",
        "cross(floor, self.impulses).sum(axis=0)",
        "cross(self.impulses, floor).sum(axis=0)",
        (P, *GROUND),
        "the ground wrench's moment with the wrong sign (f x r)",
    ),
    # --- the body builder (de Leva's masses and inertias) ---
    M(
        "A01",
        "anthropometry.py",
        "ixx, iyy, izz = (float(v) for v in mass * r**2)",
        "ixx, iyy, izz = (float(v) for v in mass * r)",
        ("tests/test_anthropometry.py",),
        "a segment's inertia m r, not m r^2 (the radius of gyration not squared)",
    ),
    M(
        "A02",
        "anthropometry.py",
        "row.length_mm / 1000.0 / ref_h * h",
        "row.length_mm / 100.0 / ref_h * h",
        ("tests/test_anthropometry.py",),
        "de Leva's segment lengths read as cm (mm -> m by 1/100)",
    ),
    M(
        "A03",
        "anthropometry.py",
        "r = np.array([row.r_long, row.r_sag, row.r_trans]) * length",
        "r = np.array([row.r_sag, row.r_long, row.r_trans]) * length",
        ("tests/test_anthropometry.py",),
        "a horizontal segment's (the foot's) long and sagittal radii on the wrong axes",
    ),
    M(
        "A04",
        "anthropometry.py",
        "c_r = (m * c - m_t * c_t) / m_r",
        "c_r = (m * c + m_t * c_t) / m_r",
        (
            "tests/test_anthropometry.py",
            "tests/test_toes.py::test_rearfoot_and_toes_together_are_de_levas_foot",
        ),
        "the rearfoot's centre of mass with the toes' added, not removed",
    ),
    M(
        "A05",
        "anthropometry.py",
        "if not 0.8 <= scale <= 1.25:",
        "if not 0.8 <= scale <= 1.5:",
        ("tests/test_anthropometry.py",),
        "measured lengths that stretch the rest of the chain by up to 1.5 accepted (valid 1.25)",
    ),
    M(
        "A06",
        "anthropometry.py",
        "row.mass * (2 if name in BILATERAL else 1)",
        "row.mass * (1 if name in BILATERAL else 1)",
        ("tests/test_anthropometry.py",),
        "the limbs counted once in the mass fractions' sum (the masses do not add up)",
    ),
    M(
        "B01",
        "body.py",
        "effort=effort * self.mass_scale,",
        "effort=effort,",
        ("tests/test_body.py",),
        "joint torque limits not scaled with the body's mass",
    ),
    M(
        "B02",
        "body.py",
        "lower=math.radians(rng.lower),",
        "lower=rng.lower,",
        ("tests/test_body.py",),
        "a joint's lower limit written in degrees, not radians",
    ),
    M(
        "B03",
        "body.py",
        'hip = _mirror((0.0, d["hip_joint_half_width"], 0.0), side)',
        'hip = (0.0, d["hip_joint_half_width"], 0.0)',
        ("tests/test_body.py",),
        "both hips on the left (the right hip not mirrored)",
    ),
    M(
        "B04",
        "body.py",
        "dynamics = _urdf().Dynamics(damping=passive.damping * self.mass_scale, friction=0.0)",
        "dynamics = _urdf().Dynamics(damping=passive.damping, friction=0.0)",
        ("tests/test_body.py",),
        "passive joint damping not scaled with the body's mass",
    ),
    # --- dynamics checks ---
    M(
        "D01",
        "dynamics.py",
        "Theta = R @ inertia.inertia @ R.T",
        "Theta = R.T @ inertia.inertia @ R",
        ("tests/test_dynamics.py",),
        "the reference dynamics' inertia turned to world axes the wrong way (transpose)",
    ),
    M(
        "D02",
        "dynamics.py",
        "(height * f[:, 0] - m[:, 1]) / fz",
        "(height * f[:, 0] + m[:, 1]) / fz",
        ("tests/test_dynamics.py",),
        "the centre of pressure's x with the moment's sign flipped",
    ),
    M(
        "D03",
        "dynamics.py",
        "g -= m * J_S.T @ g0",
        "g += m * J_S.T @ g0",
        ("tests/test_dynamics.py",),
        "the reference gravity vector with the wrong sign",
    ),
    # --- model checks (URDF validation) ---
    M(
        "K01",
        "model/checks.py",
        "if np.any(rgba < 0) or np.any(rgba > 1):",
        "if np.any(rgba < 0) or np.any(rgba > 255):",
        ("tests/test_robustness.py::test_a_urdf_that_urdfdom_would_misread_is_refused",),
        "a material colour out of [0, 1] accepted (checked against 255)",
    ),
    M(
        "K02",
        "model/checks.py",
        "dup = sorted({n for n in links if links.count(n) > 1})",
        "dup = sorted({n for n in links if links.count(n) > 2})",
        ("tests/test_robustness.py::test_a_urdf_that_urdfdom_would_misread_is_refused",),
        "a link defined twice accepted (only three times refused)",
    ),
    # --- the constraint layer ---
    M(
        "C01",
        "constraints/quaternion.py",
        "return np.array([2.0 * xdot[iq : iq + 4] @ xdot[iq : iq + 4] for iq, _ in self.cmap.quats])",  # noqa: E501
        "return np.array([xdot[iq : iq + 4] @ xdot[iq : iq + 4] for iq, _ in self.cmap.quats])",
        ("tests/test_constraints.py",),
        "the quaternion norm's drift |Q'|^2, not 2 |Q'|^2",
    ),
    M(
        "C02",
        "constraints/quaternion.py",
        "J[row, iq : iq + 4] = 2.0 * x[iq : iq + 4]",
        "J[row, iq : iq + 4] = x[iq : iq + 4]",
        ("tests/test_constraints.py",),
        "the quaternion norm's Jacobian Q^T, not 2 Q^T",
    ),
    M(
        "C03",
        "constraints/foot.py",
        "return pin.getFrameJacobian(model, data, self.frame_id, LOCAL)",
        "return pin.getFrameJacobian(model, data, self.frame_id, WORLD_ALIGNED)",
        ("tests/test_constraints.py",),
        "a weld's Jacobian in world-aligned axes while its drift is local",
    ),
    M(
        "C04",
        "constraints/foot.py",
        "return pin.getFrameClassicalAcceleration(model, data, self.frame_id, WORLD_ALIGNED).linear",  # noqa: E501
        "return pin.getFrameAcceleration(model, data, self.frame_id, WORLD_ALIGNED).linear",
        ("tests/test_constraints.py",),
        "a point contact's drift the spatial, not the classical, acceleration",
    ),
    M(
        "C05",
        "constraints/foot.py",
        "return np.concatenate([R @ force[:3], R @ force[3:]])",
        "return np.concatenate([R @ force[:3], force[3:]])",
        (P, "tests/test_constraints.py"),
        "a weld's torque left in the sole's axes, reported as world",
    ),
    M(
        "C06",
        "constraints/foot.py",
        "return np.array([data.joints[self.joint_id].joint_q[0] - self.anchor])",
        "return np.array([self.anchor - data.joints[self.joint_id].joint_q[0]])",
        (
            "tests/test_constraints.py",
            "tests/test_toes.py::test_a_welded_foot_locks_its_toes_and_the_lock_is_internal",
        ),
        "a joint lock's residual with the wrong sign (its Baumgarte term pushes away)",
    ),
    M(
        "L01",
        "constraints/limits.py",
        "keep = r < margin",
        "keep = r > margin",
        RANGES,
        "the joint ranges keep the rows far from their limits, not those near",
    ),
    M(
        "L02",
        "constraints/limits.py",
        "sgn = np.where(side == 0, 1.0, -1.0)[:, None]",
        "sgn = np.where(side == 0, -1.0, 1.0)[:, None]",
        RANGES,
        "a ball joint's range rows pushing towards its limits",
    ),
    M(
        "L03",
        "constraints/limits.py",
        "out = [self.lo - x, x - self.hi]",
        "out = [self.lo - x, self.hi - x]",
        (*RANGES, "tests/test_ik_hidden.py"),
        "a hinge's excess over its upper bound measured the wrong way",
    ),
    M(
        "G01",
        "constraints/ground.py",
        "gap[2::3] = np.where(contacts.phi >= 0.0, contacts.phi, corr * contacts.phi) / dt",
        "gap[2::3] = -np.where(contacts.phi >= 0.0, contacts.phi, corr * contacts.phi) / dt",
        GROUND,
        "the ground's gap term with the wrong sign (a point above the floor pulled down)",
    ),
    M(
        "G02",
        "constraints/ground.py",
        "gaps.append(np.where(r >= 0.0, r, corr * r) / dt)",
        "gaps.append(-np.where(r >= 0.0, r, corr * r) / dt)",
        RANGES,
        "a joint range's gap term with the wrong sign",
    ),
    M(
        "G03",
        "constraints/ground.py",
        "lam = d * np.array(res.retrieveConstraintImpulses())",
        "lam = np.array(res.retrieveConstraintImpulses())",
        GROUND,
        "the contact impulses not scaled back from the Jacobi-scaled problem",
    ),
    M(
        "G04",
        "constraints/ground.py",
        "rows = (J[:3] - skew @ J[3:])",
        "rows = (J[:3] + skew @ J[3:])",
        ("tests/test_ground.py::test_the_contact_jacobian_is_pinocchios_point_contact_jacobian",),
        "a contact point's velocity with w x p the wrong way round",
    ),
    M(
        "G05",
        "constraints/ground.py",
        "world[self._sphere, 2] -= self.s_radius",
        "world[self._sphere, 2] += self.s_radius",
        ("tests/test_ground.py::test_detection_finds_the_points_each_shape_places_one_by_one",),
        "a sphere's lowest point at its top",
    ),
    M(
        "G06",
        "constraints/ground.py",
        "d = axis[:, 2:3] * axis",
        "d = -axis[:, 2:3] * axis",
        ("tests/test_ground.py::test_detection_finds_the_points_each_shape_places_one_by_one",),
        "a tilted cylinder rim's lowest point found off its rim",
    ),
    M(
        "G07",
        "constraints/ground.py",
        "found = GroundContacts(points, points[:, 2].copy(), joints, local, rows, ids)",
        "found = GroundContacts(points, points[:, 1].copy(), joints, local, rows, ids)",
        ("tests/test_kernels.py",),
        "the compiled detection's signed distances read off the wrong axis",
    ),
    M(
        "G08",
        "simulation/ground.py",
        "model.armature = p.model.armature + dt * np.diag(D) + (dt * dt) * np.diag(K)",
        "model.armature = p.model.armature + np.diag(D) + (dt * dt) * np.diag(K)",
        ("tests/test_ground.py::test_diagonal_implicit_gains_are_an_armature",),
        "the implicit damping as an armature without its step",
    ),
    # --- integrators, simulation plant and loop ---
    M(
        "I01",
        "integrators.py",
        "return space.integrate(q, dt * v_new), v_new",
        "return space.integrate(q, dt * v), v_new",
        ("tests/test_integrators.py",),
        "semi-implicit Euler moving q with the old velocity (explicit Euler)",
    ),
    M(
        "I02",
        "integrators.py",
        "d = sixth * (v + 2.0 * (kq2 + kq3) + kq4)",
        "d = sixth * (v + kq2 + kq3 + kq4)",
        ("tests/test_integrators.py",),
        "RK4's position weights 1 1 1 1, not 1 2 2 1",
    ),
    M(
        "S01",
        "simulation/loop.py",
        "every = max(1, int(round(1.0 / (scene.record_rate * dt))))",
        "every = max(1, int(1.0 / (scene.record_rate * dt)))",
        (
            P + "::test_a_run_takes_the_nearest_whole_number_of_steps_and_records",
            *(TS + "record_rate_and_trajectory_file",),
        ),
        "the recording interval truncated, not rounded (a sample off the record rate)",
    ),
    M(
        "S02",
        "simulation/loop.py",
        "return max(1, int(round(self.scene.duration / self.scene.dt)))",
        "return max(1, int(self.scene.duration / self.scene.dt))",
        (
            P + "::test_a_run_takes_the_nearest_whole_number_of_steps_and_records",
            *(TS + "record_rate_and_trajectory_file", TS + "switch_contacts_follows_a_schedule"),
        ),
        "the number of steps truncated (a run one step short)",
    ),
    M(
        "S03",
        "simulation/plant.py",
        "return StepResult(t + dt, pin.integrate(self.model, q, dt * v_new), v_new, torque,",
        "return StepResult(t + dt, pin.integrate(self.model, q, dt * v), v_new, torque,",
        (
            P + "::test_the_plants_inlined_euler_step_moves_q_with_the_new_velocity",
            *(
                TS + "plain_aba_equals_the_kkt_path_without_constraints",
                TS + "quaternion_formulations_give_the_same_motion",
                TS + "standing_scene_holds_and_forces_carry_the_weight",
            ),
        ),
        "the plant's inlined Euler step moving q with the old velocity",
    ),
    M(
        "S04",
        "simulation/plant.py",
        "tau = self._zero if tau is None else tau * self.mask",
        "tau = self._zero if tau is None else tau",
        (
            P + "::test_a_controllers_force_on_the_root_is_masked_off",
            *(
                TS + "standing_scene_holds_and_forces_carry_the_weight",
                TS + "switched_off_effect_equals_zeroed_effect",
                "tests/test_scene.py",
            ),
        ),
        "joint efforts not masked off the free flyer (the root actuated)",
    ),
    # --- file readers ---
    M(
        "T01",
        "motion/markers.py",
        "pos = markers.positions @ OPENSIM_TO_OURS if y_up else markers.positions",
        "pos = markers.positions @ OPENSIM_TO_OURS.T if y_up else markers.positions",
        (TM + "test_trc_round_trip_and_opensim_layout",),
        "write_trc turning our axes to OpenSim's with the reading rotation (a transpose)",
    ),
    M(
        "T02",
        "motion/markers.py",
        "for p in pos[i] * 1000.0:",
        "for p in pos[i] * 100.0:",
        (TM + "test_trc_round_trip_and_opensim_layout",),
        "write_trc writing cm under Units mm",
    ),
    M(
        "T03",
        "motion/markers.py",
        "times.append(float(cells[1]))",
        "times.append(float(cells[0]))",
        (TM + "test_trc_round_trip_and_opensim_layout",),
        "read_trc's time read from the frame-number column",
    ),
    M(
        "T04",
        "motion/markers.py",
        "time = (first + np.arange(pos.shape[0])) / rate",
        "time = np.arange(pos.shape[0]) / rate",
        (
            P + "::test_a_c3d_starting_at_frame_100_starts_at_1_s",
            *(
                TM + "test_c3d_markers",
                "tests/test_c3d_plates.py::test_a_y_up_lab_is_turned_to_ours",
            ),
        ),
        "a C3D's times starting at 0, not at its first frame",
    ),
    M(
        "X01",
        "motion/c3d_file.py",
        "frames = max(last - first + 1, 0) if last != 0xFFFF else 0",
        "frames = max(last - first, 0) if last != 0xFFFF else 0",
        C3D,
        "a C3D's frame count one short (a file truncated by a frame passes the check)",
    ),
    M(
        "X02",
        "motion/c3d_file.py",
        "word = 4 if sign else 2",
        "word = 2 if sign else 4",
        C3D,
        "a C3D's data word size: float files taken as integer ones",
    ),
    M(
        "X03",
        "motion/c3d_file.py",
        "n = abs(kind)",
        "n = kind",
        (P + "::test_a_c3d_character_parameter_counts_its_characters", *C3D),
        "a C3D character parameter's size negative (type -1 not made absolute)",
    ),
    M(
        "ST1",
        "motion/storage.py",
        "return (len(self.time) - 1) / float(self.time[-1] - self.time[0])",
        "return len(self.time) / float(self.time[-1] - self.time[0])",
        (
            TM + "test_storage_reads_opensim_layout",
            TM + "test_storage_round_trip_is_exact",
            TM + "test_storage_opensim4_header_and_whitespace",
        ),
        "a table's rate n / T, not (n - 1) / T",
    ),
    M(
        "ST2",
        "motion/storage.py",
        "if step[i] < 1.0 / MAX_RATE:",
        "if step[i] < 0.0:",
        (
            TM + "test_storage_errors_name_the_problem",
            "tests/test_bad_input.py::test_a_bad_storage_file_is_a_motion_file_error",
            "tests/test_bad_input.py::test_marker_trajectories_need_increasing_times",
        ),
        "samples closer than 1 / MAX_RATE accepted (only going back refused)",
    ),
    M(
        "V01",
        "motion/bvh.py",
        "R = R @ np.array([pin.exp3(_AXIS[c[0]] * math.radians(a)) for a in x])",
        "R = np.array([pin.exp3(_AXIS[c[0]] * math.radians(a)) for a in x]) @ R",
        (TM + "test_bvh_reads_as_blender_does", TM + "test_bvh_errors"),
        "a BVH joint's rotation channels composed extrinsically, not intrinsically",
    ),
    M(
        "V02",
        "motion/bvh.py",
        'out[:, j] = out[:, joint.parent] + np.einsum("nij,nj->ni", Rp, p)',
        "out[:, j] = out[:, joint.parent] + p",
        (TM + "test_bvh_reads_as_blender_does", TM + "test_bvh_errors"),
        "a BVH joint's offset not turned by its parent (local taken as world)",
    ),
    M(
        "KP1",
        "motion/markers.py",
        "pts = pts @ OPENSIM_TO_OURS.T",
        "pts = pts @ OPENSIM_TO_OURS",
        (
            P + "::test_y_up_keypoints_turn_to_our_z_up",
            *(
                TM + "test_keypoints_layouts",
                "tests/test_cameras.py::test_keypoints_check_their_shapes",
            ),
        ),
        "Y-up keypoints turned to our axes the wrong way (a transpose)",
    ),
    M(
        "CA1",
        "motion/cameras.py",
        "return -self.rotation.T @ self.translation",
        "return -self.rotation @ self.translation",
        (
            "tests/test_cameras.py::test_projection_is_opencvs_and_its_jacobian_is_exact",
            "tests/test_cameras.py::test_look_at_sees_the_world_upright",
            "tests/test_cameras.py::test_a_calibration_round_trips_and_pose2sims_own_file_reads",
        ),
        "a camera's optical centre without the transpose",
    ),
    M(
        "CA2",
        "motion/cameras.py",
        "D[..., 1, 1] = radial + 2 * g * b * b + 6 * p1 * b + 2 * p2 * a",
        "D[..., 1, 1] = radial + 2 * g * b * b + 2 * p1 * b + 2 * p2 * a",
        ("tests/test_cameras.py::test_projection_is_opencvs_and_its_jacobian_is_exact",),
        "the projection Jacobian's tangential-distortion term 2 p1 b, not 6 p1 b",
    ),
    # --- IK, ID, loads, scaling ---
    M(
        "IK1",
        "motion/ik.py",
        "lever[:, 0, 4], lever[:, 0, 5] = z, -y",
        "lever[:, 0, 4], lever[:, 0, 5] = -z, y",
        (P, TM + "test_ik_keeps_joints_in_range_and_skips_missing_markers"),
        "a marker's Jacobian with the lever arm's sign flipped",
    ),
    M(
        "IK2",
        "motion/ik.py",
        "smooth = smoothing * total / dt**2",
        "smooth = -smoothing * total / dt**2",
        (
            P + "::test_ik_smoothing_holds_a_joint_towards_the_frame_before",
            *(
                TM + "test_ik_keeps_joints_in_range_and_skips_missing_markers",
                "tests/test_ik_hidden.py",
            ),
        ),
        "IK's smoothing pushing the joints away from the frame before",
    ),
    M(
        "IK3",
        "motion/ik.py",
        "if down or _inward(balls, q, q_new):  # taken",
        "if down:  # taken",
        ("tests/test_real_trial.py::test_subject01_with_ball_ranges_holds_the_trunk_at_its_bound",),
        "IK's step that brings a ball joint back into its range refused when it raises the cost",
    ),
    M(
        "LD1",
        "motion/loads.py",
        "return np.hstack([self.force, np.cross(self.point, self.force) + self.torque])",
        "return np.hstack([self.force, np.cross(self.force, self.point) + self.torque])",
        (
            TM + "test_load_from_wrench_is_exact_and_on_the_plane",
            TM + "test_loads_round_trip_through_opensim_files",
            TM + "test_loads_are_carried_with_the_feet_the_markers_show",
        ),
        "a load's moment about the origin f x p, not p x f",
    ),
    M(
        "LD2",
        "motion/loads.py",
        "[np.interp(time, self.time, w[:, i], left=0.0, right=0.0) for i in range(6)]",
        "[np.interp(time, self.time, w[:, i]) for i in range(6)]",
        (
            P + "::test_a_load_is_zero_outside_its_times",
            *(
                TM + "test_load_from_wrench_is_exact_and_on_the_plane",
                TM + "test_loads_round_trip_through_opensim_files",
                TM + "test_loads_are_carried_with_the_feet_the_markers_show",
            ),
        ),
        "a load held at its last value outside its times (not zero)",
    ),
    M(
        "LD3",
        "motion/loads.py",
        "return np.column_stack([table.column(prefix + n) for n in names]) @ R.T",
        "return np.column_stack([table.column(prefix + n) for n in names]) @ R",
        (TM + "test_loads_round_trip_through_opensim_files", TM + "test_loads_need_a_side"),
        "a Y-up loads file turned to our axes the wrong way (a transpose)",
    ),
    M(
        "LE1",
        "motion/inverse_dynamics.py",
        "cols.append(np.vstack([R.T, R.T @ pin.skew(p - o)]) @ turn)",
        "cols.append(np.vstack([R.T, R.T @ pin.skew(o - p)]) @ turn)",
        (
            TM + "test_estimated_loads_of_a_standing_body_carry_its_weight",
            "tests/test_floor_fit.py::test_the_floor_height_and_centre_of_pressure",
        ),
        "load estimation: a sole point's moment arm with the wrong sign",
    ),
    M(
        "LE2",
        "motion/inverse_dynamics.py",
        "wrench[s][i] += np.concatenate([fk, np.cross(p, fk)])",
        "wrench[s][i] += np.concatenate([fk, np.cross(fk, p)])",
        (
            TM + "test_estimated_loads_of_a_standing_body_carry_its_weight",
            "tests/test_floor_fit.py::test_the_floor_height_and_centre_of_pressure",
        ),
        "load estimation: the estimated wrench's moment f x p",
    ),
    M(
        "SC1",
        "motion/scale.py",
        'ratios[s] = np.array([r, r_h, r_h] if s == "foot" else [r_h, r_h, r])',
        'ratios[s] = np.array([r_h, r_h, r] if s == "foot" else [r, r_h, r_h])',
        SCALE,
        "scaling: the markers carried along the wrong axis (a foot's length on z)",
    ),
    M(
        "SC2",
        "motion/scale.py",
        "r_h = height / params.height",
        "r_h = params.height / height",
        SCALE,
        "scaling: the stature ratio inverted",
    ),
    # --- the tracking and walking QPs' tasks ---
    M(
        "CT1",
        "control/tasks.py",
        "ang = a[3:] + self.kp * (R @ pin.log3(R.T @ M_r.rotation))",
        "ang = a[3:] + self.kp * pin.log3(R.T @ M_r.rotation)",
        ("tests/test_control.py",),
        "a frame task's orientation error left in the frame's axes, used as world",
    ),
    M(
        "CT2",
        "control/tasks.py",
        "a = dw_ref + self.kp * (R @ pin.log3(R.T @ R_ref))",
        "a = dw_ref + self.kp * (R @ pin.log3(R_ref.T @ R))",
        ("tests/test_control.py",),
        "an orientation task's error with the wrong sign",
    ),
    M(
        "CT3",
        "control/tasks.py",
        "return A, self.kd * (k_ref - k) - dA @ v",
        "return A, self.kd * (k_ref - k) + dA @ v",
        ("tests/test_control.py",),
        "the angular-momentum task's drift term with the wrong sign",
    ),
    M(
        "CT4",
        "motion/tracking.py",
        "placement: float = 1.0",
        "placement: float = 0.5",
        ("tests/test_real_trial.py::test_subject01_tracked_to_the_end",),
        "a tracked swing foot landing half the capture point's error (its lateral error grows)",
    ),
    # --- gait events, analysis, report ---
    M(
        "GA1",
        "walking/gait.py",
        "state = value > off if state else value > on",
        "state = value > on if state else value > off",
        (
            "tests/test_gaitlab.py::test_events_need_the_force_to_fall_below_the_lower_threshold",
            *GAIT,
        ),
        "the contact hysteresis' thresholds swapped",
    ),
    M(
        "GA2",
        "walking/gait.py",
        'table["cadence"].append(120.0 / T)',
        'table["cadence"].append(60.0 / T)',
        GAIT,
        "cadence in strides per minute, reported as steps per minute",
    ),
    M(
        "GA3",
        "walking/gait.py",
        'out["braking"] = -window("grf_anterior", 0, half, np.min)',
        'out["braking"] = window("grf_anterior", 0, half, np.min)',
        GAIT,
        "the braking peak reported negative",
    ),
    M(
        "GA4",
        "walking/gait.py",
        "return float(np.mean(np.abs(c - mean) <= sds * sd))",
        "return float(np.mean(np.abs(c - mean) <= sd))",
        (
            "tests/test_gaitlab.py::test_in_band_is_as_wide_as_it_is_asked",
            *("tests/test_gaitlab.py::test_a_curve_in_band_and_its_roughness", *GAIT),
        ),
        "in_band's width 1 SD whatever sds says",
    ),
    M(
        "GA5",
        "walking/gait.py",
        "M[j] -= _sums(cross(pts[on] - O[j][at[on]], forces[on]), at[on], n)",
        "M[j] += _sums(cross(pts[on] - O[j][at[on]], forces[on]), at[on], n)",
        ("tests/test_gait.py::test_joint_moments_are_the_plants_torques",),
        "the gait record's joint moments with the ground's forces added, not taken away",
    ),
    M(
        "RP1",
        "walking/report.py",
        '("com_vertical", "CoM vertical excursion", "cm", 100.0, (3.0, 5.0), "Gard 2004"),',
        '("com_vertical", "CoM vertical excursion", "cm", 10.0, (3.0, 5.0), "Gard 2004"),',
        (P + "::test_the_gait_table_reports_each_value_in_its_unit", *GAIT),
        "the report's CoM vertical excursion m -> cm by 10",
    ),
    # --- the cache ---
    M(
        "CH1",
        "cache.py",
        "Path(tmp).unlink(missing_ok=True)",
        "Path(tmp).exists()",
        ("tests/test_cache.py::test_an_interrupted_write_leaves_no_file",),
        "an interrupted cache write leaves its temporary file behind",
    ),
    M(
        "CH2",
        "cache.py",
        "M.homogeneous.ravel(), inertia.mass,",
        "M.homogeneous.ravel(),",
        ("tests/test_cache.py::test_the_name_changes_with_the_body_and_every_number",),
        "the body's digest blind to the segments' masses",
    ),
    M(
        "CH3",
        "cache.py",
        'return (Path(root) if root else Path.home() / ".cache" / "humanoid") / kind',
        'return Path.home() / ".cache" / "humanoid" / kind',
        ("tests/test_cache.py::test_a_cache_that_cannot_be_written_warns_and_the_fit_is_returned",),
        "$HUMANOID_CACHE ignored",
    ),
    # --- studies ---
    M(
        "SY1",
        "study/spec.py",
        'doc = {"run": self.run, "scene": self.scene, "fixed": self.fixed, "keep": self.keep}',
        'doc = {"run": self.run, "scene": self.scene, "keep": self.keep}',
        (
            P + "::test_a_studys_fixed_parameters_are_in_its_fingerprint",
            *(
                "tests/test_study.py::test_the_same_study_again_runs_nothing",
                "tests/test_study.py::test_the_shipped_studies_load_and_their_folders_are_guarded",
            ),
        ),
        "a study's fingerprint blind to its fixed parameters (old results reused)",
    ),
    M(
        "SY2",
        "study/spec.py",
        "return [args[i] for i in rng.integers(0, len(args), size=n)]",
        "return [args[i] for i in rng.integers(0, len(args) - 1, size=n)]",
        ("tests/test_study.py::test_samples_are_seeded_and_clipped",),
        "a sampled choice never draws its last option",
    ),
    M(
        "SY3",
        "study/spec.py",
        "x = args[0] * np.exp(np.log(args[1]) * rng.normal(size=n))",
        "x = args[0] * np.exp(args[1] * rng.normal(size=n))",
        (
            P + "::test_a_lognormal_sample_has_the_median_and_geometric_sd_asked",
            *("tests/test_study.py::test_samples_are_seeded_and_clipped",),
        ),
        "a lognormal sample's geometric SD used as the log's SD",
    ),
    # --- walking: norms, clinical angles, the footstep plan ---
    M(
        "W01",
        "walking/norms.py",
        "return i, i + 1, (x - s[i]) / (s[i + 1] - s[i])",
        "return i, i + 1, (s[i + 1] - x) / (s[i + 1] - s[i])",
        ("tests/test_gaitlab.py",),
        "the normative curves interpolated between speed classes the wrong way",
    ),
    M(
        "W02",
        "walking/clinical.py",
        "-hip[0], sign * hip[1], sign * hip[2], knee[0], -ankle[0],",
        "hip[0], sign * hip[1], sign * hip[2], knee[0], -ankle[0],",
        ("tests/test_gaitlab.py", *GAIT),
        "the clinical hip flexion with the wrong sign",
    ),
    M(
        "W03",
        "walking/clinical.py",
        "a = math.atan2(R[0, 2], R[2, 2])",
        "a = math.atan2(R[2, 0], R[2, 2])",
        ("tests/test_gaitlab.py", *GAIT),
        "the Y-X-Z angles' first angle read off the transposed matrix",
    ),
    M(
        "W04",
        "walking/plan.py",
        "self._position_before(OTHER_SIDE[s.side], i)",
        "self._position_before(s.side, i)",
        (
            "tests/test_walking.py::test_zmp_reference_stays_in_the_support_polygon",
            "tests/test_walking.py::test_preview_control_tracks_the_zmp_reference",
        ),
        "the ZMP reference under the swinging foot, not the stance foot",
    ),
    M(
        "W05",
        "walking/reference.py",
        "slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])",
        "slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j - 1])",
        ("tests/test_reference.py::test_the_centre_of_mass_plan_reads_like_np_interp",),
        "the centre-of-mass plan's lookup dividing by two sample spacings (and wrapping at 0)",
    ),
    # --- effects, the ball-joint fusion, the MuJoCo export, the scene's checks ---
    M(
        "E01",
        "effects.py",
        "return -self.k * pin.difference(model, self.rest, q)",
        "return -self.k * pin.difference(model, q, self.rest)",
        (P + "::test_joint_springs_pull_towards_their_rest_posture", "tests/test_forces.py"),
        "joint springs pushing away from their rest posture",
    ),
    M(
        "E02",
        "effects.py",
        "f = -self.k * r - self.c * np.minimum(J @ v, 0.0)",
        "f = -self.k * r - self.c * np.maximum(J @ v, 0.0)",
        (
            FORCES + "joint_limit_forces_push_back_inside",
            FORCES + "joint_range_springs_conserve_momentum_and_energy",
        ),
        "the joint-limit damper resisting the way back in, not the way further out",
    ),
    M(
        "E05",
        "effects.py",
        "return self.start <= t + TIME_EPS and t + TIME_EPS < self.end",
        "return self.start <= t and t < self.end",
        (
            P + "::test_a_push_of_0_1_plus_0_2_s_acts_on_exactly_200_steps_of_1_ms",
            FORCES + "a_push_changes_momentum_by_its_impulse",
        ),
        "a push's window compared without its tolerance (0.1 + 0.2 s acts on 201 steps)",
    ),
    M(
        "E04",
        "effects.py",
        "model, data, q, self.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED",
        "model, data, q, self.frame_id, pin.ReferenceFrame.LOCAL",
        (FORCES + "a_push_changes_momentum_by_its_impulse",),
        "a push's world force applied through the frame's local Jacobian",
    ),
    M(
        "F03",
        "fusion.py",
        "W = W @ _rot(self.axes[:, 2], angles[2])",
        "W = _rot(self.axes[:, 2], angles[2]) @ W",
        ("tests/test_fusion.py",),
        "a fused ball joint's third hinge composed first, not last",
    ),
    M(
        "F02",
        "fusion.py",
        "E = np.swapaxes(G @ Rs, -1, -2) @ cols",
        "E = (G @ Rs) @ cols",
        ("tests/test_fusion.py",),
        "hinge rates mapped to a ball's angular velocity without the rotation's transpose",
    ),
    M(
        "EX1",
        "export.py",
        "return np.array([c[3], c[0], c[1], c[2]])",
        "return np.array([c[0], c[1], c[2], c[3]])",
        ("tests/test_export.py",),
        "MuJoCo quaternions written x y z w, not w x y z",
    ),
    M(
        "EX2",
        "export.py",
        "size = _fmt(np.asarray(shape.halfSide))",
        "size = _fmt(2.0 * np.asarray(shape.halfSide))",
        ("tests/test_export.py",),
        "MuJoCo boxes written with their full sizes (MuJoCo's size is half)",
    ),
    M(
        "SV1",
        "scene.py",
        "if e.damping < 0 or e.springs < 0:",
        "if e.damping < 0:",
        ("tests/test_scene.py", "tests/test_robustness.py"),
        "a scene's negative joint springs accepted",
    ),
    M(
        "SV2",
        "scene.py",
        "if not (math.isfinite(g.margin) and 0 < g.margin <= 0.1):",
        "if not (math.isfinite(g.margin) and 0 < g.margin <= 1.0):",
        ("tests/test_scene.py", "tests/test_ground.py::test_ground_scene_errors_name_the_key"),
        "a ground contact margin up to 1 m accepted (valid up to 0.1 m)",
    ),
    # --- the viewer's HTML export ---
    M(
        "VW1",
        "viewer.py",
        "n = int(math.floor((t[-1] - t[0]) / speed * fps)) + 1",
        "n = int(math.floor((t[-1] - t[0]) / speed * fps))",
        (TV + "animation_frames_follow_the_trajectory_at_the_chosen_speed",),
        "an animation one frame short (the last state never shown)",
    ),
    M(
        "VW2",
        "viewer.py",
        "time_sim = t[0] + k * speed / fps",
        "time_sim = t[0] + k / fps",
        (
            TV + "animation_keys_are_the_trajectory_interpolated_at_their_times",
            *(TV + "animation_frames_follow_the_trajectory_at_the_chosen_speed",),
        ),
        "the animation's playback speed ignored when sampling",
    ),
    M(
        "VW3",
        "viewer.py",
        "s = float(np.clip((time_sim - t[i]) / (t[i + 1] - t[i]), 0.0, 1.0))",
        "s = float(np.clip((t[i + 1] - time_sim) / (t[i + 1] - t[i]), 0.0, 1.0))",
        (
            TV + "animation_keys_are_the_trajectory_interpolated_at_their_times",
            *(
                TV + "animation_frames_follow_the_trajectory_at_the_chosen_speed",
                TV + "frame_places_bodies_com_and_force_arrows",
            ),
        ),
        "the animation interpolating between records the wrong way",
    ),
    M(
        "VW4",
        "viewer.py",
        "return pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), f / n).toRotationMatrix()",
        "return pin.Quaternion.FromTwoVectors(np.array([0.0, 1.0, 0.0]), f / n).toRotationMatrix()",
        (
            TV + "frame_places_bodies_com_and_force_arrows",
            TV + "the_ground_force_is_an_arrow_at_its_centre_of_pressure",
            TV + "a_push_is_an_arrow_on_the_pushed_point_while_it_acts",
        ),
        "force arrows turned from +Y, not +Z (they point the wrong way)",
    ),
)


# --------------------------------------------------------------------------------------------


def tracked_files(root: Path) -> list[str]:
    out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                         cwd=root, check=True, capture_output=True)  # fmt: skip
    return [p for p in out.stdout.decode().split("\0") if p]


def copy_tree(root: Path, dest: Path) -> None:
    """The files of ``root`` git tracks or would (not the ignored ones), as they are in the
    working tree (edits and new files included)."""
    for rel in tracked_files(root):
        src = root / rel
        if src.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)


def check_table(root: Path = ROOT, mutations=MUTATIONS) -> list[str]:
    """Problems with the table: ids repeated, an old text not found exactly once, a change
    that changes nothing, a test file that does not exist."""
    problems = []
    ids = [m.id for m in mutations]
    problems += [f"{i}: id repeated" for i in sorted({i for i in ids if ids.count(i) > 1})]
    for m in mutations:
        path = root / "humanoid" / m.file
        if not path.is_file():
            problems.append(f"{m.id}: no file humanoid/{m.file}")
            continue
        n = path.read_text().count(m.old)
        if n != 1:
            problems.append(f"{m.id}: {m.old!r} occurs {n} times in humanoid/{m.file}")
        if m.old == m.new:
            problems.append(f"{m.id}: the new text is the old")
        if "\n" in m.old or "\n" in m.new:
            problems.append(f"{m.id}: not one line")
        for t in m.tests:
            if not (root / t.split("::")[0]).is_file():
                problems.append(f"{m.id}: no test file {t}")
    return problems


def run_tests(copy: Path, tests, timeout: float, env: dict) -> tuple[str, float, str]:
    """(outcome, seconds, first failing test): outcome passed, failed or timeout."""
    cmd = [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *tests]
    start = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=copy, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, start_new_session=True)  # fmt: skip
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # (the run and any child it started)
        proc.communicate()
        return "timeout", time.monotonic() - start, ""
    except BaseException:  # (interrupted: no run left behind)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        raise
    seconds = time.monotonic() - start
    text = out.decode(errors="replace")
    if proc.returncode == 0:
        return "passed", seconds, ""
    # (a node id may hold spaces, in its parameters' ids: up to the " - " of the message)
    found = re.findall(r"^(?:FAILED|ERROR) (.+?)(?: - .*)?$", text, flags=re.M)
    first = found[0] if found else f"(pytest exit {proc.returncode}): " + text.strip()[-300:]
    return "failed", seconds, first


def baseline_runs(mutations) -> dict[str, list[str]]:
    """The unmutated runs: per test file, every selection of it the table makes (the whole
    file if one mutation names it whole), in one pytest run each."""
    by_file: dict[str, set[str]] = {}
    for t in (t for m in mutations for t in m.tests):
        by_file.setdefault(t.split("::")[0], set()).add(t)
    return {f: [f] if f in ts else sorted(ts) for f, ts in sorted(by_file.items())}


def forget_bytecode(path: Path) -> None:
    for pyc in (path.parent / "__pycache__").glob(f"{path.stem}.*.pyc"):
        pyc.unlink(missing_ok=True)


def measure(mutations, timeout: float, log=print) -> dict:
    """Plant each mutation alone in a copy of the repository and run its tests."""
    problems = check_table(ROOT, mutations)
    if problems:
        raise SystemExit("the table does not apply:\n  " + "\n  ".join(problems))
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="humanoid-mutation-") as tmp:
        copy = Path(tmp) / "repo"
        copy_tree(ROOT, copy)
        env = dict(os.environ, PYTHONPATH=str(copy), HUMANOID_CACHE=str(Path(tmp) / "cache"),
                   OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "1"))  # fmt: skip
        env.pop("PYTEST_ADDOPTS", None)
        baseline = {}
        for path, tests in baseline_runs(mutations).items():
            outcome, seconds, first = run_tests(copy, tests, timeout, env)
            baseline[path] = {"outcome": outcome, "seconds": round(seconds, 1), "first": first,
                              "tests": len(tests)}  # fmt: skip
            log(f"baseline {path} ({len(tests)} selections): {outcome} in {seconds:.0f} s {first}")
        bad = {t: b for t, b in baseline.items() if b["outcome"] != "passed"}
        if bad:
            raise SystemExit(f"the unmutated code fails its tests, no measurement: {bad}")
        results = []
        for m in mutations:
            path = copy / "humanoid" / m.file
            original = path.read_text()
            assert original.count(m.old) == 1, m.id
            try:
                path.write_text(original.replace(m.old, m.new))
                forget_bytecode(path)
                outcome, seconds, first = run_tests(copy, list(m.tests), timeout, env)
            finally:
                path.write_text(original)
                forget_bytecode(path)
            status = {"passed": "survived", "failed": "killed", "timeout": "timeout"}[outcome]
            results.append(asdict(m) | {"status": status, "seconds": round(seconds, 1),
                                        "killed_by": first})  # fmt: skip
            log(f"{m.id} {status:8s} {seconds:5.0f} s  {m.bug}  {first}")
    return {"baseline": baseline, "results": results,
            "wall_seconds": round(time.monotonic() - started, 1)}  # fmt: skip


def summary(results) -> dict:
    status = [r["status"] for r in results]
    return {"planted": len(status), "killed": status.count("killed"),
            "survived": status.count("survived"), "timeout": status.count("timeout")}  # fmt: skip


def markdown(measured: dict) -> str:
    results = measured["results"]
    s = summary(results)
    lines = [
        "# Planted one-line bugs",
        "",
        "Measured by `scripts/mutation.py` (docs/development.md): each bug planted alone in a "
        "copy of the repository, the tests named run; killed if one fails.",
        "",
        f"**{s['planted']} planted: {s['killed']} killed, {s['survived']} survived, "
        f"{s['timeout']} timed out** (a timeout counts as killed).",
    ]
    first = measured.get("first")
    if first:
        lines += [
            "",
            f"The whole table's first run ({measured['wall_seconds'] / 60:.0f} min): "
            f"{first['planted']} planted, {first['killed']} killed, {first['survived']} "
            f"survived, {first['timeout']} timed out; the survivors were then given tests (or, "
            "where the bug changed nothing, replaced) and run again: `before` below.",
        ]
    else:
        lines += ["", f"Harness wall time {measured['wall_seconds'] / 60:.0f} min."]
    for h in measured.get("history", ()):  # earlier whole runs, on earlier tables and tests
        lines += ["", f"Earlier: {h['note']}"]
    before = any("before" in r for r in results)  # (a rerun merged: each one's earlier status)
    head = ["id", "file", "bug", "status", *(["before"] if before else []), "s", "killed by"]
    lines += ["", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in results:
        by = r["killed_by"].replace("|", "\\|")
        cells = [r["id"], r["file"], r["bug"], r["status"],
                 *([r.get("before", "")] if before else []), f"{r['seconds']:.0f}", by]  # fmt: skip
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def merged(old: dict, new: dict) -> dict:
    """A whole run's results (``old``) with some mutations run again (``new``): the table's
    current order, each rerun's earlier status kept as ``before``, ids no longer in the table
    dropped; ``first`` keeps the whole run's figure."""
    previous = {r["id"]: r for r in old["results"]}
    rerun = {r["id"]: r for r in new["results"]}
    results = []
    for m in MUTATIONS:
        if m.id in rerun:
            r = dict(rerun[m.id])
            before = previous.get(m.id)
            r["before"] = before.get("before", before["status"]) if before else "new"
            results.append(r)
        elif m.id in previous:
            results.append(previous[m.id])
    return {"baseline": old["baseline"] | new["baseline"], "results": results,
            "wall_seconds": old["wall_seconds"], "first": old.get("first") or old["summary"],
            "history": old.get("history", []),
            "reruns": [*old.get("reruns", []), {"ids": sorted(rerun),
                                                "wall_seconds": new["wall_seconds"]}]}  # fmt: skip


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--only", nargs="+", metavar="ID", help="these mutations only")
    p.add_argument("--list", action="store_true", help="print the table and stop")
    p.add_argument("--jobs", type=int, default=1, help="mutations at once (only 1 is supported)")
    p.add_argument("--timeout", type=float, default=TIMEOUT, help="[s] per mutation")
    p.add_argument("--update", action="store_true",
                   help="with --only: merge the results into STEM.json (a whole run's) and "
                        "write STEM.md again")  # fmt: skip
    p.add_argument("-o", "--output", type=Path, default=None,
                   help="the results' stem (default docs/bench/mutation, or results/mutation with "
                        "--only): STEM.md and STEM.json")  # fmt: skip
    a = p.parse_args(argv)
    # a kill ends the run in progress and removes the copy (as Ctrl-C does)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    if a.jobs != 1:
        p.error("--jobs: only 1 (the runs share the copy of the repository)")
    mutations = MUTATIONS
    if a.only:
        unknown = set(a.only) - {m.id for m in MUTATIONS}
        if unknown:
            p.error(f"--only: no mutation {sorted(unknown)}")
        mutations = tuple(m for m in MUTATIONS if m.id in a.only)
    if a.list:
        for m in mutations:
            print(f"{m.id}  humanoid/{m.file}: {m.bug}\n      {m.old!r}\n   -> {m.new!r}\n"
                  f"      tests: {' '.join(m.tests)}")  # fmt: skip
        problems = check_table(ROOT, mutations)
        print(f"{len(mutations)} mutations; " + ("; ".join(problems) or "the table applies"))
        return 1 if problems else 0
    if a.update and not a.only:
        p.error("--update goes with --only (the mutations to run again)")
    measured = measure(mutations, a.timeout, log=lambda s: print(s, flush=True))
    stem = a.output or ROOT / (
        "results/mutation" if a.only and not a.update else "docs/bench/mutation"
    )
    stem.parent.mkdir(parents=True, exist_ok=True)
    if a.update:
        measured = merged(json.loads(Path(f"{stem}.json").read_text()), measured)
    measured["summary"] = summary(measured["results"])
    Path(f"{stem}.json").write_text(json.dumps(measured, indent=1) + "\n")
    Path(f"{stem}.md").write_text(markdown(measured))
    print(json.dumps(measured["summary"]), f"wall {measured['wall_seconds']:.0f} s",
          f"-> {stem}.md, {stem}.json")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
