"""A person's gait cycle, optimised through the body's rigid contact dynamics.

One half stride, from the right heel strike to the left heel strike, with left-right symmetry:
the state at its end is the mirror image (through y = 0) of the state at its start, moved one
step forward, so the whole stride repeats it mirrored. Three phases whose durations are
optimised:

1. **loading** (double support): the right heel down (its two heel points), the left foot on
   its toes (the metatarsal heads and the toe tips) until the left toe-off;
2. **foot flat**: the right foot's heel, metatarsal heads and toe tips down, the left foot in
   swing;
3. **heel off**: the right foot on its toes, the rearfoot rolling about the metatarsal heads,
   until the left heel strikes.

A body without toes rolls over its toe tips in phase 3 and carries its weight on the heel and
toe points in phase 2.

Two objectives (:data:`OBJECTIVES`):

- ``"tracking"``: the published joint angles, ground forces and the ankle's, knee's and
  hip's sagittal moments at the speed (Schwartz et al. 2008, at the body's dimensionless speed,
  weighted by their standard deviations; the pelvis's obliquity and rotation at a quarter of
  theirs), the arms' swing (a 30 deg arc opposite their own hips), the opposite foot's toe-off
  at half an adult's double support, the cycle time of
  :func:`~humanoid.walking.norms.choose_gait`; the trunk and the arms' other joints within a
  few degrees of standing; plus a small effort. From scratch it is solved twice: first
  without the hip's and knee's moments, the arms' swing and the trunk's and pelvis's tighter
  weights, then with them from the first optimum (a continuation).
- ``"predictive"``: effort, as the predictive-simulation literature writes it (Falisse et al.
  2019, J R Soc Interface 16:20190402: torques squared, joint accelerations squared as a
  regulariser), plus the torques' rate, and the pelvis near level; the cycle time, hence
  cadence and step length, free.

Joints no curve follows (the hips' rotation, the ankles' inversion, the toes; and in the
predictive objective the trunk and the arms) stay near standing (a small weight).

Both keep the mean speed. :func:`optimise_gait` builds and solves one; a :class:`GaitSolution`
maps it back to the body (quaternions) and to a full stride.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import ConvergenceError, OptimalControlError
from ._casadi import ca
from .coordinates import OcpModel, build_ocp_model
from .cycle import (
    NODES,
    OBJECTIVES,
    GaitSolution,
    cache_dir,
    contact_points,
    default_speed,
    gait_file,
    gait_phases,
    load_gait,
    save_gait,
    stored,
)
from .problem import Collocation

__all__ = [
    "OBJECTIVES", "GaitSolution", "cache_dir", "fourier", "gait_cycle", "gait_phases",
    "load_gait", "optimise_gait", "save_gait",
]  # fmt: skip

HARMONICS = 8  # Fourier terms of a normative curve over the cycle
MU = 0.8
# [rad] the cycle keeps this far inside the joints' ranges: a walk tracks it on a plant that
# enforces them (riding them, the trunk's bending and the elbows' extension at their limits,
# the tracker's QP met the plant's range constraints and had no solution)
RANGE_MARGIN = 0.05

# Weights of the tracking objective's terms (each a mean of squares over the half cycle, in
# the curves' standard deviations), and of the regularisers.
W_ANGLE = 1.0
W_FORCE = 1.0
# the sagittal moments tracked: (the OCP model's hinge, the norm's curve, weight per SD). The
# ankle's sets the push-off and the centre of pressure's run along the foot; the hip's is
# added in a second solve, from the first's optimum (a continuation: from the kinematic fit
# with both, IPOPT ran over 700 iterations without settling; from the ankle's optimum, the male
# body with toes took 43 more, and its hip moment went from 50 % of the cycle inside the
# norm's band to 100 % on the right and 69 % on the left). The arms' swing and the pelvis's
# and trunk's tighter weights wait for the second solve too (in the first, the male body's took
# 891 iterations, 449 s). The knee's joined them in revision 3: untracked, the 1.95 m, 100 kg
# male's cycle flexed the knee 26 deg in the loading response with an extensor moment of
# 0.9-1.0 N m/kg (the norm's 0.41 +- 0.48), inside the band for 67 % of the cycle, and the
# 1.50 m, 45 kg female's push-off power peaked at 4.35 W/kg; tracked (warm-started from those
# cycles, 10 steps walked), 98 and 100 % in the band and 3.76 W/kg, the other bands held. Not
# tracked, as measured on the male body: the ankle's power (Error_In_Step_Computation after 915).
FIRST_MOMENTS = (("ankle_flexion", "ankle_plantarflexion_moment", 1.0),)
MOMENTS = (
    *FIRST_MOMENTS,
    ("hip_flexion", "hip_extension_moment", 1.0),
    ("knee", "knee_extension_moment", 1.0),
)
# From a warm start IPOPT begins near the end of its barrier path and keeps the iterate where
# it is (the default mu 0.1 and bound push move it back to the middle first): the male cycle
# from 1.38 to 1.25 m/s in 27 iterations against 101 with mu_init 1e-4 alone and 166 with the
# defaults (measured before the hip's moment was tracked; with it, 45 iterations, 54 s).
WARM = {
    "ipopt.mu_init": 1e-4, "ipopt.warm_start_init_point": "yes",
    "ipopt.warm_start_bound_push": 1e-6, "ipopt.warm_start_mult_bound_push": 1e-6,
}  # fmt: skip
# IPOPT stops at an acceptable point: 15 iterations in a row with the constraints met to 1e-7,
# the scaled optimality error under 1e-3 and the objective changing under 1e-4 of itself. The
# tracking objective's last 0.5 % otherwise takes IPOPT hundreds of iterations of full steps
# along a shallow valley (the male cycle: 8.039 at iteration 445, 8.003 at 631, still moving).
ACCEPTABLE = {
    "ipopt.acceptable_tol": 1e-3, "ipopt.acceptable_iter": 15,
    "ipopt.acceptable_constr_viol_tol": 1e-7, "ipopt.acceptable_obj_change_tol": 1e-4,
}  # fmt: skip
# The first of the two solves from scratch only starts the second: it stops at a rougher point
# (5 iterations in a row with the optimality error under 1e-2 and the objective changing under
# 1 % of itself). Its path along the valley is long and fragile: the male body's first solve
# took 567 iterations at one commit and 1615 at the next, with the same objective written in
# another order (the rounding differs); stopped rough, 309, and the second solve reached the
# same optimum to 1e-12 in 48 (236 s in all, against 443 and 940).
ROUGH = ACCEPTABLE | {
    "ipopt.acceptable_tol": 1e-2, "ipopt.acceptable_iter": 5,
    "ipopt.acceptable_obj_change_tol": 1e-2,
}  # fmt: skip
# The pelvis's obliquity and rotation per SD: with the trunk and arms near standing (below)
# the pelvis makes up the rest; at 1, the male cycle's obliquity swung 13.7 deg (the norm's
# range 8.8 +- 2.1) and its rotation 14.4 (9.7 +- 3.8); at 16, 9.5 and 10.0.
W_PELVIS = 16.0
# The trunk (lumbar and thoracic joints) and the arms, per (UPPER_SD deg)^2 from standing, and
# each shoulder's flexion along ARM_ARC deg opposite its own hip's flexion (a 30 deg arc, Perry
# & Burnfield 2010) with the same SD. With only the small posture weight the optimum used them
# as reaction masses to shape the ground forces: the male cycle's arms swung 102 deg in phase
# with their own hips, its trunk bent and twisted 24 deg (to its ranges).
UPPER = ("lumbar", "thoracic", "shoulder", "elbow")
UPPER_SD = 5.0
ARM_ARC = 30.0
W_EVENT = 10.0  # per SD of the opposite foot's toe-off [fraction of the cycle]
W_POSTURE = 0.1  # per rad^2 from standing, joints no curve tracks
W_EFFORT = 0.01
# The predictive objective's effort, and its pelvis's roll and yaw from level [per rad^2].
# Measured on the female body from her tracking cycle: with W_EFFORT the joints' accelerations
# (W_ACCELERATION) outweighed the torques 9 to 1, and the optimum took long slow steps (94
# steps/min, 0.83 m); at 1, 106 steps/min and 0.73 m. With the pelvis free it turned 50 deg
# in the walk (people about 10); at 1 per rad^2 20 deg, at 4 8.3.
W_EFFORT_PREDICTIVE = 1.0
W_PELVIS_PREDICTIVE = 4.0
W_ACCELERATION = 1e-4  # per (rad/s^2)^2
W_FORCE_REG = 1e-3  # per point force, in body weights^2
W_RATE = 1e-3  # per ((tau / limit) / s)^2


def fourier(values: np.ndarray, harmonics: int = HARMONICS) -> np.ndarray:
    """Least-squares Fourier coefficients (a0, a1, b1, ...) of a periodic curve sampled over
    0-100 % (the last sample repeats the first)."""
    y = np.asarray(values, dtype=float)[:-1]
    phi = np.arange(len(y)) / len(y)
    return np.linalg.lstsq(_basis(phi, harmonics), y, rcond=None)[0]


def fourier_eval(coefficients, phi):
    """The curve at phase ``phi`` [fraction of the cycle] (numbers or casadi)."""
    n = (len(coefficients) - 1) // 2
    out = coefficients[0]
    for i in range(1, n + 1):
        w = 2 * math.pi * i * phi
        out = out + coefficients[2 * i - 1] * _cos(w) + coefficients[2 * i] * _sin(w)
    return out


def _cos(w):
    return ca.cos(w) if isinstance(w, ca.MX | ca.SX) else np.cos(w)


def _sin(w):
    return ca.sin(w) if isinstance(w, ca.MX | ca.SX) else np.sin(w)


def _basis(phi, harmonics):
    cols = [np.ones_like(phi)]
    for i in range(1, harmonics + 1):
        cols += [np.cos(2 * np.pi * i * phi), np.sin(2 * np.pi * i * phi)]
    return np.column_stack(cols)


class _Targets:
    """The normative curves the tracking objective follows, as Fourier series."""

    def __init__(self, dimensionless_speed: float) -> None:
        from ..walking.norms import ADULT, FREE_DIMENSIONLESS_SPEED, norms

        n = norms()
        mean, sd = {}, {}
        for name in ("pelvis_tilt", "pelvis_obliquity", "pelvis_rotation", "hip_flexion",
                     "hip_adduction", "knee_flexion", "ankle_dorsiflexion", "grf_vertical",
                     "grf_anterior", *(curve for _, curve, _ in MOMENTS)):  # fmt: skip
            # the model's pelvis is level standing; the lab's tilts forward (Norms.curve)
            m, s = n.curve(name, dimensionless_speed, pelvis="level")
            mean[name], sd[name] = m, s
        self.coefficients = {k: fourier(v) for k, v in mean.items()}
        hip_arc = np.ptp(fourier_eval(self.coefficients["hip_flexion"], np.linspace(0, 1, 101)))
        self._arm_gain = -ARM_ARC / hip_arc
        self.sd = {k: float(np.mean(v)) for k, v in sd.items()}
        # the opposite foot's toe-off ends the first double support: at the adults' free speed,
        # half their double support (the middle of ADULT's band; the children's is a few % of
        # the cycle shorter); at other speeds moved as Schwartz's moves with the speed (longer
        # when slower: 13.2 % of the cycle at 0.8 m/s against 9.5 at the free speed), with
        # Schwartz's SD
        (lo, hi), _, _ = ADULT["double_support"]
        event, event_sd = n.event("opposite_foot_off", dimensionless_speed)
        free, _ = n.event("opposite_foot_off", FREE_DIMENSIONLESS_SPEED)
        self.events = {"opposite_foot_off": ((lo + hi) / 4 + event - free, event_sd)}

    def arm(self, phi):
        """[deg] a shoulder's flexion from standing at its own leg's phase ``phi``: the hip's
        flexion about its mean, scaled to :data:`ARM_ARC` and reversed."""
        hip = self.coefficients["hip_flexion"]
        return self._arm_gain * (fourier_eval(hip, phi) - hip[0])

    def __call__(self, name, phi):
        return fourier_eval(self.coefficients[name], phi)


def optimise_gait(h, speed=None, objective: str = "tracking", warm=None, nodes=NODES,
                  verbose: bool = False, max_iter: int = 3000) -> GaitSolution:  # fmt: skip
    """Optimise a half stride of ``h`` (see the module).

    Args:
        h: The body (:class:`humanoid.Humanoid`, with heel and toe contact frames).
        speed: [m/s] mean speed; default the body's free speed (to the cm/s).
        objective: One of :data:`OBJECTIVES`.
        warm: A :class:`GaitSolution` to start from (a neighbouring speed or body, the same
            nodes); default a kinematic fit of the norms (``walking.reference.fit_cycle``).
        nodes: Collocation intervals per phase.
    """
    from ..walking.norms import choose_gait
    from ..walking.reference import fit_cycle, leg_length

    if objective not in OBJECTIVES:
        raise OptimalControlError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    om = build_ocp_model(h) if warm is None or warm.om.body is not h else warm.om
    ell = leg_length(h)
    speed = default_speed(h) if speed is None else float(speed)
    gait = choose_gait(speed, ell)
    half = gait["cycle"] / 2
    flat_at = gait["opposite_foot_off"] * gait["cycle"]
    heel_off = 0.65 * gait["foot_off"] * gait["cycle"]
    guess_d = [flat_at, heel_off - flat_at, half - heel_off]
    bounds = [(0.3 * d, 2.5 * d) for d in guess_d]
    phases = gait_phases(om, guess_d, nodes, bounds)
    c = Collocation(om, phases, mu=MU, periodic=True, range_margin=RANGE_MARGIN)
    opti, N = c.opti, c.N
    T = c.total_duration()
    # symmetry and speed
    perm, sign = om.mirror
    step = opti.variable()
    opti.subject_to(c.X[0, 0] == 0)
    opti.subject_to(c.X[:, N] == sign * c.X[perm, 0] + ca.vertcat(step, ca.DM.zeros(om.n - 1)))
    opti.subject_to(c.V[:, N] == sign * c.V[perm, 0])
    opti.subject_to(step == speed * T)
    if objective == "tracking":
        opti.subject_to(T == half)
    else:
        opti.subject_to(opti.bounded(0.3, T, 1.0))
    # guess
    if warm is None:
        x_guess, v_guess, a_guess = _kinematic_guess(om, fit_cycle(h, speed), c, guess_d)
        c.guess(x_guess, v_guess, a_guess, durations=guess_d)
        opti.set_initial(step, x_guess[-1, 0] - x_guess[0, 0])
    else:
        c.warm_start(warm.solution)
        opti.set_initial(step, warm.step_length * speed / warm.speed)
    standing = om.from_body(h.standing_configuration())
    terms = objective_terms(c, om, objective, gait, standing)
    cost = sum(terms.values())
    if warm is None and objective == "tracking":
        # first without the hip's and knee's moments, the arms' swing and the pelvis's and
        # trunk's tighter weights, stopped at a rough point (ROUGH); then with them from there,
        # as from a warm start
        first = objective_terms(c, om, objective, gait, standing, first=True)
        sol = c.solve(sum(first.values()), terms=first, verbose=verbose, max_iter=max_iter,
                      options=ROUGH)  # fmt: skip
        if sol.success:
            c.warm_start(sol)
            opti.set_initial(step, float(sol.x[-1, 0] - sol.x[0, 0]))
            again = c.solve(cost, terms=terms, verbose=verbose, max_iter=max_iter,
                            options=ACCEPTABLE | WARM)  # fmt: skip
            sol = replace(again, iterations=sol.iterations + again.iterations,
                          seconds=sol.seconds + again.seconds)  # fmt: skip
    else:
        options = ACCEPTABLE | (WARM if warm is not None else {})
        sol = c.solve(cost, terms=terms, verbose=verbose, max_iter=max_iter, options=options)
    points = {s: contact_points(om, s) for s in ("left", "right")}
    return GaitSolution(sol, om, speed, objective, points, tuple(nodes))


def _kinematic_guess(om, cycle, c, durations):
    """The fitted cycle's first half at the node times: x, v and a (N + 1, n)."""
    frames = len(cycle.phase)
    half = frames // 2
    x = om.from_body(cycle.q[: half + 1])
    t_fit = np.arange(half + 1) * cycle.period / frames
    t_nodes = [0.0]
    for ph, d in zip(c.phases, durations, strict=True):
        t_nodes += list(t_nodes[-1] + d * np.arange(1, ph.intervals + 1) / ph.intervals)
    t_nodes = np.array(t_nodes) * t_fit[-1] / t_nodes[-1]
    xs = np.column_stack([np.interp(t_nodes, t_fit, x[:, i]) for i in range(om.n)])
    vs = np.gradient(xs, t_nodes, axis=0)
    return xs, vs, np.gradient(vs, t_nodes, axis=0)


def objective_terms(c: Collocation, om: OcpModel, objective: str, gait: dict | None, standing,
                    first: bool = False, heading=None) -> dict:  # fmt: skip
    """The objective's terms (``standing``: the posture the untracked joints stay near: a
    fixed target, so that the optimum does not depend on the initial guess; ``first``: the
    tracking objective's first solve from scratch, see :func:`_tracking_terms`; ``heading``:
    the problem is a whole stride along a curve, see :func:`_tracking_terms`)."""
    N, w = c.N, c.node_weights()
    T = c.total_duration()
    times = c.node_times()
    limits = np.maximum(om.model.effortLimit[6:], 1.0)
    terms = {}
    effort = W_EFFORT if objective == "tracking" else W_EFFORT_PREDICTIVE
    terms["effort"] = effort * c.effort() / T
    acc = sum(w[k] * ca.sumsqr(c.A[6:, k]) for k in range(N + 1))
    terms["acceleration"] = W_ACCELERATION * acc / T
    terms["force_regulariser"] = W_FORCE_REG * c.force_regulariser() / (N + 1)
    rate = 0
    for k in range(N):
        dt = times[k + 1] - times[k]
        rate = rate + ca.sumsqr((c.tau[k + 1] - c.tau[k]) / limits) / dt
    terms["torque_rate"] = W_RATE * rate / T
    if objective == "predictive":
        # the trunk's and arms' posture stays near standing (nothing else pins it)
        upper = [i for i, n in enumerate(om.names) if any(k in n for k in UPPER)]
        terms["posture"] = W_POSTURE * _squares(c, upper, standing) / T
        level = [om.index("root_roll"), om.index("root_yaw")]
        terms["pelvis"] = W_PELVIS_PREDICTIVE * _squares(c, level, standing) / T
        return terms
    if gait is None:
        raise OptimalControlError("the tracking objective needs the gait it tracks")
    terms.update(_tracking_terms(c, om, gait, standing, first, heading))
    return terms


def _event_term(c: Collocation, targets, cycle, whole_stride: bool):
    """The double support's event: the first phase lasts until the opposite foot's toe-off,
    at the norm's time (``cycle``: the stride's duration); in a whole stride, a turn's, the
    mirrored phase too, the other foot's (free, the male's turn at 1.27 m/s took 16 % of
    double support and walked it so)."""
    event, event_sd = targets.events["opposite_foot_off"]
    supports = (0, len(c.durations) // 2) if whole_stride else (0,)
    return W_EVENT * sum(((c.durations[i] / cycle - event) / event_sd) ** 2 for i in supports)


def _tracking_terms(c: Collocation, om: OcpModel, gait: dict, standing, first: bool,
                    heading=None) -> dict:  # fmt: skip
    """The tracking objective's own terms (see :func:`objective_terms`): the norms' angles,
    ground forces and sagittal moments, the arms' swing, the double support's event, and the
    untracked joints near standing. ``first``: the first of two solves from scratch (a
    continuation), with the ankle's moment only (:data:`FIRST_MOMENTS`), the pelvis at its SD
    and the trunk and arms at the small posture weight. ``heading``: per node, the direction
    of travel [rad] (expressions): the problem is then a whole stride along a curve (not a
    half), the pelvis's rotation is tracked about the heading and the anterior force along
    it."""
    N, w = c.N, c.node_weights()
    T = c.total_duration()
    times = c.node_times()
    targets = _Targets(gait["dimensionless_speed"])
    cycle = 2 * T if heading is None else T
    idx = om.index
    rd = math.radians
    tracked = set()
    angle, force, moments = 0, 0, 0
    mass = float(sum(i.mass for i in om.model.inertias))
    sagittal = FIRST_MOMENTS if first else MOMENTS
    pelvis = 1.0 if first else math.sqrt(W_PELVIS)
    right, left = contact_points(om, "right"), contact_points(om, "left")
    right_all = sum((v for v in right.values() if v), ())
    left_all = sum((v for v in left.values() if v), ())
    for k in range(N + 1):
        phi = times[k] / cycle
        e = []
        for side, phase in (("right", phi), ("left", phi + 0.5)):
            for coord, curve in (
                (f"{side}_hip_flexion", "hip_flexion"),
                (f"{side}_knee", "knee_flexion"),
                (f"{side}_ankle_flexion", "ankle_dorsiflexion"),
                (f"{side}_hip_adduction", "hip_adduction"),
            ):
                target = rd(1) * targets(curve, phase)
                e.append((c.X[idx(coord), k] - target) / rd(targets.sd[curve]))
                tracked.add(coord)
            if not first:
                coord = f"{side}_shoulder_flexion"
                target = standing[idx(coord)] + rd(1) * targets.arm(phase)
                e.append((c.X[idx(coord), k] - target) / rd(UPPER_SD))
                tracked.add(coord)
        tilt = rd(1) * targets("pelvis_tilt", phi)
        e.append((c.X[idx("root_pitch"), k] - tilt) / rd(targets.sd["pelvis_tilt"]))
        e.append(pelvis * (c.X[idx("root_roll"), k] + rd(1) * targets("pelvis_obliquity", phi))
                 / rd(targets.sd["pelvis_obliquity"]))  # fmt: skip
        yaw = rd(1) * targets("pelvis_rotation", phi)
        if heading is not None:
            yaw = yaw + heading[k]
        e.append(pelvis * (c.X[idx("root_yaw"), k] - yaw) / rd(targets.sd["pelvis_rotation"]))
        angle = angle + w[k] * ca.sumsqr(ca.vertcat(*e))
        f = []
        for pts, phase in ((right_all, phi), (left_all, phi + 0.5)):
            F = c.foot_force(k, pts) / c.weight
            ahead = F[0] if heading is None else F[0] * _cos(heading[k]) + F[1] * _sin(heading[k])
            f.append((F[2] - targets("grf_vertical", phase)) / targets.sd["grf_vertical"])
            f.append((ahead - targets("grf_anterior", phase)) / targets.sd["grf_anterior"])
        force = force + w[k] * ca.sumsqr(ca.vertcat(*f))
        # sagittal internal moments per kg (extensor, plantarflexor +: against the hinge's
        # flexion, dorsiflexion)
        m = []
        for side, phase in (("right", phi), ("left", phi + 0.5)):
            for joint, curve, weight in sagittal:
                tau = c.tau[k][idx(f"{side}_{joint}") - 6] / mass
                m.append(math.sqrt(weight) * (-tau - targets(curve, phase)) / targets.sd[curve])
        moments = moments + w[k] * ca.sumsqr(ca.vertcat(*m))
    terms = {"events": _event_term(c, targets, cycle, whole_stride=heading is not None)}
    terms["angles"] = W_ANGLE * angle / T
    terms["forces"] = W_FORCE * force / T
    terms["moments"] = moments / T
    rest = [i for i in range(6, om.n) if om.names[i] not in tracked]
    upper = [] if first else [i for i in rest if any(k in om.names[i] for k in UPPER)]
    legs = [i for i in rest if i not in upper]
    terms["posture"] = W_POSTURE * _squares(c, legs, standing) / T
    if upper:
        terms["upper"] = _squares(c, upper, standing) / T / rd(UPPER_SD) ** 2
    return terms


def _squares(c: Collocation, rows, target):
    """The quadrature of ``|X[rows] - target[rows]|^2`` over the nodes."""
    w = c.node_weights()
    return sum(w[k] * ca.sumsqr(c.X[rows, k] - target[rows]) for k in range(c.N + 1))


def gait_cycle(h, speed=None, objective: str = "tracking", *, cache: bool = True,
               verbose: bool = False) -> GaitSolution:  # fmt: skip
    """A body's optimised half stride at ``speed``: from the package's data or the user's cache
    (:func:`cache_dir`) if it is there, else optimised (warm-started from the nearest speed
    stored for the body, or for the predictive objective from the tracking one) and, with
    ``cache``, stored.

    Raises:
        ConvergenceError: IPOPT did not converge (the message names its status).
    """
    om = build_ocp_model(h)
    speed = round(default_speed(h) if speed is None else float(speed), 2)
    have = stored(om, objective)
    if speed in have:
        return load_gait(have[speed], h)
    warm = None
    if have:
        nearest = min(have, key=lambda s: abs(s - speed))
        warm = load_gait(have[nearest], h)
    elif objective != "tracking":
        tracking = stored(om, "tracking")
        if tracking:
            warm = load_gait(tracking[min(tracking, key=lambda s: abs(s - speed))], h)
    g = optimise_gait(h, speed, objective, warm=warm, verbose=verbose)
    if not g.solution.success:
        raise ConvergenceError(
            f"the {objective} gait at {speed} m/s did not converge: IPOPT {g.solution.status} "
            f"after {g.solution.iterations} iterations"
        )
    if cache:
        save_gait(g, cache_dir() / gait_file(om, speed, objective))
    return g
