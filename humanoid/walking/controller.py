"""Whole-body walking controller: a task-space inverse-dynamics QP that outputs joint torques.

Variables: the generalised acceleration dv (nv) and three force components at each of the four
sole corners of every stance foot. Solved with ProxQP (proxsuite's dense solver, kept between
ticks and warm-started; qpsolvers' one-shot interface could not) at every control tick:

- equalities: the six floating-base rows of M dv + h = J_c^T f (the base is not actuated), and
  for each stance foot the same acceleration constraint the simulator enforces on its weld,
  J dv + J'v = -2 alpha J v - beta^2 e (identical Baumgarte terms, so that the simulated
  accelerations equal the controller's when the model is right);
- inequalities: a friction pyramid per corner, |f_x|, |f_y| <= (mu / sqrt 2) f_z and f_z >= 0
  (together: unilateral contact, friction, and the centre of pressure inside the sole);
- costs: centre-of-mass tracking (preview-control reference), swing-foot pose, an upright
  pelvis and torso, a posture, and a small force regularisation.

Only tau = (M dv + h - J_c^T f)[6:] leaves the controller: the simulator integrates its own
constrained dynamics; nothing is placed kinematically.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..constraints import Weld
from ..constraints.foot import packed_rows
from ..constraints.limits import JointRanges
from ..constraints.solve import stack
from ..control.qp import (
    JointWrenches,
    WarmQP,
    checked,
    dynamics_terms,
    frame_jacobians,
    range_damper,
    whole_body_qp,
)
from ..control.tasks import (
    CentreOfMassTask,
    ForceTask,
    FrameTask,
    OrientationTask,
    PostureTask,
    TaskStack,
)
from ..dynamics import TreeDynamics
from ..effects import Effect
from ..linalg import spd_solve
from ..model import SIDES
from .clinical import torso_frame

__all__ = ["ControllerGains", "HeldForces", "WalkingController"]

RANGE_MARGIN = 0.3  # [rad] joint-range rows this close to a limit enter the QP
RANGE_TIME = 0.05  # [s] the velocity damper's time constant (see update)

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True)
class ControllerGains:
    """Task gains [1/s^2 for kp, 1/s for kd] and weights of the walking QP."""

    com_kp: float = 100.0
    com_kd: float = 20.0
    swing_kp: float = 400.0
    swing_kd: float = 40.0
    trunk_kp: float = 100.0
    trunk_kd: float = 20.0
    posture_kp: float = 25.0
    posture_kd: float = 10.0
    w_com: float = 1.0
    w_swing: float = 1.0
    w_trunk: float = 0.3
    w_posture: float = 1e-2
    w_force: float = 1e-2  # pull of the corner forces towards the planned load sharing
    mu: float = 0.6  # the controller's friction coefficient (below the checked one)


class WalkingController(Effect):
    """Joint torques that walk a humanoid along a plan (see the module docstring).

    Args:
        h: The Humanoid. model: the simulator's model (with its gravity).
        plan: The :class:`~humanoid.walking.plan.FootstepPlan`.
        com: ``(t, c, dc, ddc)`` horizontal CoM reference from preview control.
        z_c: CoM height [m]. q_posture: posture reference.
        baumgarte: The simulator's Baumgarte gains, used in the stance-foot constraints.
        period: The control period [s] (the joint ranges' velocity damper looks this far).
    """

    name = "walking"
    velocity_dependent = True

    def __init__(self, h, model, plan, com, z_c, q_posture, baumgarte, gains=None, period=1e-3):
        self.h, self.model, self.plan = h, model, plan
        self.data = model.createData()
        self.t_ref, self.c_ref, self.dc_ref, self.ddc_ref = com
        self.z_c = z_c
        # (c, dc, ddc) with z at every sample of the reference, for one interpolation
        self._com_table = np.zeros((len(self.t_ref), 3, 3))
        self._com_table[:, 0, :2], self._com_table[:, 0, 2] = self.c_ref, z_c
        self._com_table[:, 1, :2], self._com_table[:, 2, :2] = self.dc_ref, self.ddc_ref
        self.q_posture = np.array(q_posture, dtype=float)
        self.baumgarte = baumgarte
        self.gains = gains or ControllerGains()
        self.sole = {s: h.sole_id(s) for s in SIDES}
        self.corners = {s: [h.frame_id(n) for n in h.require_contact_points(s)] for s in self.sole}
        self.tau = np.zeros(model.nv)
        self.weight = h.mass * float(np.linalg.norm(model.gravity.linear))
        self.last = None  # (dv, forces by side) of the last solve
        self.ranges = JointRanges(h)
        self.period = period  # [s] the control period (torques are held over it)
        self.every = 1  # the QP is solved every this many simulation steps
        # between QP solves: "forces" (the solve's contact forces held, the accelerations
        # nearest its that the state allows: held_torques) or "torques" (its torques held)
        self.hold = "forces"
        self._held = None
        # the hinges' range rows (JointRanges.hinge_rows): constant, +-1 on one velocity each
        self._hinge_J = self.ranges.hinge_rows(q_posture)[1]
        self._hinge_v = np.argmax(np.abs(self._hinge_J), axis=1)
        self._hinge_sign = self._hinge_J[np.arange(len(self._hinge_J)), self._hinge_v]
        self._rows_for: tuple | None = None  # (the welds, their soles' frames), by stance
        self.fresh = False  # whether the QP was solved at this tick's state
        self._solved_for: set | None = None  # the stance set of the last solve
        # (the plant's active constraints, the welds by side, in order, the sides) of this tick
        self._stance: tuple | None = None
        self.qp = WarmQP(eps_abs=1e-8, max_iter=10_000, primal=1e-8, dual=1e-5)
        self._zero = np.zeros(model.nv)
        # each side's corners: their joints, and their places in their joints' frames
        self._corner_joints = {s: [model.frames[f].parentJoint for f in self.corners[s]]
                               for s in SIDES}  # fmt: skip
        self._corner_local = {s: np.array([model.frames[f].placement.translation
                                           for f in self.corners[s]]) for s in SIDES}  # fmt: skip
        self._holds = HeldForces(model)  # the last solve's holds, for held_torques

    def force(self, model, data, t, q, v):
        return self.tau

    def before_step(self, sim, k: int, t: float, q, v) -> None:
        """The run loop's hook: a new QP at every control tick, and whenever a foot lands or
        lifts off, with the plant's stance welds (and the locks of the feet's own hinges)."""
        active = sim.active_constraints()  # the same list while no foot lands or lifts
        if self._stance is None or self._stance[0] is not active:
            welds = {c.side: c.constraints for c in sim.contacts if c.attached}
            held = [w for s in SIDES if s in welds for w in welds[s]]
            self._stance = (active, welds, held, set(welds))
        _, welds, held, sides = self._stance
        self.fresh = k % self.every == 0 or sides != self._solved_for
        if self.fresh:
            self.update(t, q, v, welds)
            self._solved_for = sides
        elif self.hold == "forces":
            self.tau = self.held_torques(q, v, held)

    def held_torques(self, q, v, welds) -> np.ndarray:
        """Between control ticks: the torques under which the plant's feet carry exactly the
        last solve's contact forces f (inside their friction pyramids, the centre of pressure
        inside the soles), with the accelerations nearest the last solve's dv that the body
        can have under them: dv + d, d the smallest change that satisfies the base's six
        unactuated rows M_b (dv + d) + h_b - J_cb^T f = 0 and the welds' rows
        J (dv + d) = gamma (the plant's, Baumgarte terms included), keeps the joint-range rows
        the solve held at their damper's bound, and stops any hinge that would cross its own
        within the step. Then tau = M (dv + d) + h - J_c^T f on the joints: one RNEA with f as
        external wrenches (held in the feet's joint frames, which the welds keep still) and a
        small least-squares."""
        model, data = self.model, self.data
        dv, Jr, Jh_dv = self._held
        tau = self._holds.compiled(q, v, dv)
        if tau is not None:
            return tau
        fext = self._holds.fext()
        pin.forwardKinematics(model, data, q, v, self._zero)
        pin.computeJointJacobians(model, data, q)
        J, gamma = self._weld_rows(welds, v)
        M = pin.crba(model, data, q)  # both triangles (tests/test_dynamics.py)
        tau = pin.rnea(model, data, q, v, dv, fext)
        # hinges that dv would drive through their damper in the next step get the damper's
        # bound as their acceleration (r' + dt r'' >= -r / RANGE_TIME; J is constant on a hinge:
        # +-1 on its velocity, so J v is a signed gather of v, and J dv was taken at the solve)
        r, _ = self.ranges.hinge_rows(q)
        floor = (-r / RANGE_TIME - self._hinge_sign * v[self._hinge_v]) * (self.every / self.period)
        short = Jh_dv < floor
        m, nr = len(J), len(Jr)
        ns = int(np.count_nonzero(short))
        A = np.empty((6 + m + nr + ns, model.nv))  # the rows, stacked
        A[:6] = M[:6]
        A[6 : 6 + m] = J
        rhs = np.zeros(len(A))
        rhs[:6] = tau[:6]
        rhs[6 : 6 + m] = J @ dv - gamma
        if nr:
            A[6 + m : 6 + m + nr] = Jr
        if ns:
            Jh = self._hinge_J[short]
            A[6 + m + nr :] = Jh
            rhs[6 + m + nr :] = Jh @ dv - floor[short]
        d = A.T @ spd_solve(A @ A.T, rhs, ridge=1e-12, overwrite=True)  # (rows may be dependent)
        tau -= M @ d
        tau[:6] = 0.0
        return tau

    def _weld_rows(self, welds, v) -> tuple[np.ndarray, np.ndarray]:
        """J and gamma of the stance welds (:func:`~humanoid.constraints.solve.stack`) at the
        kinematics in ``self.data``: a weld's residual reads its sole's placement, so only
        those frames are updated (their ids found once per stance)."""
        model, data = self.model, self.data
        if self._rows_for is None or self._rows_for[0] is not welds:
            self._rows_for = (welds, [w.frame_id for w in welds if isinstance(w, Weld)])
        for frame in self._rows_for[1]:
            pin.updateFramePlacement(model, data, frame)
        return stack(model, data, welds, v, self.baumgarte)

    # -- references ----------------------------------------------------------------------
    def com_reference(self, t):
        t_ref = self.t_ref
        k = min(max((t - t_ref[0]) / (t_ref[1] - t_ref[0]), 0.0), len(t_ref) - 1.0)
        i = min(int(k), len(t_ref) - 2)
        s = k - i
        out = (1.0 - s) * self._com_table[i] + s * self._com_table[i + 1]  # c, dc, ddc
        return out[0], out[1], out[2]

    # -- the QP ----------------------------------------------------------------------------
    def update(self, t: float, q, v, welds: dict) -> np.ndarray:
        """Solve the QP at (t, q, v) with the plant's stance welds; returns and holds tau."""
        model, data, g = self.model, self.data, self.gains
        M, hvec = dynamics_terms(model, data, q, v)
        stance = [s for s in ("left", "right") if s in welds]
        nf = 12 * len(stance)
        tasks = TaskStack(model, data, q, v)
        c_ref, dc_ref, ddc_ref = self.com_reference(t)
        tasks.add(CentreOfMassTask(c_ref, dc_ref, ddc_ref, g.com_kp, g.com_kd, g.w_com))
        ref = self.plan.swing_reference(t)
        swing = self.plan.swing(t)
        if ref is not None and swing.side not in welds:  # the swing foot, level
            p_ref, v_ref, a_ref = ref
            zero = np.zeros(3)
            tasks.add(FrameTask(self.sole[swing.side], pin.SE3(np.eye(3), p_ref), g.swing_kp,
                                g.swing_kd, g.w_swing, np.concatenate([v_ref, zero]),
                                np.concatenate([a_ref, zero])))  # fmt: skip
        for frame in self.trunk_frames():  # upright pelvis and torso (their yaw left free)
            tasks.add(OrientationTask(frame, None, g.trunk_kp, g.trunk_kd, g.w_trunk,
                                      tilt_only=True))  # fmt: skip
        tasks.add(PostureTask(self.q_posture, g.posture_kp, g.posture_kd, g.w_posture))
        # load sharing: the stance feet share the weight as the ZMP reference says, so that a
        # foot is unloaded when the plan lifts it (forces are in body weights)
        f_ref = np.zeros(nf)
        for k, share in enumerate(self.shares(t, stance, data)):
            f_ref[12 * k + 2 : 12 * k + 12 : 3] = share / 4.0
        Jc = frame_jacobians(model, data, [f for s in stance for f in self.corners[s]])
        # the stance welds' rows exactly as the plant stacks them (same Baumgarte terms)
        welded = self._holds.weld_rows(self, q, v, stance, welds)
        Jr, bound = range_damper(self.ranges, q, v, self.period, RANGE_MARGIN, RANGE_TIME)
        weight = self.weight
        p = whole_body_qp(M, hvec, weight, tasks, Jc, g.mu, forces=[ForceTask(f_ref, g.w_force)],
                          motion=[welded], bounds=[(-Jr, bound)], ridge=1e-9)  # fmt: skip
        x, _ = p.solve(self.qp, relax=False)
        self.tau, dv, f = p.torques(checked(x, "walking", t, self.qp), M, hvec, weight)
        self.last = (dv, {s: f[4 * k : 4 * k + 4] for k, s in enumerate(stance)})
        if self.every > 1:
            # the range rows the solve holds at their damper's bound keep their acceleration
            tight = -Jr @ dv >= bound - 1e-6 * np.maximum(1.0, np.abs(bound))
            self._held = (dv, Jr[tight], self._hinge_J @ dv)
            self._holds.hold(self, stance, welds, f, *self._held[1:])
        return self.tau

    def shares(self, t, stance, data) -> list[float]:
        """Planned fraction of the weight on each stance foot, from the ZMP reference."""
        if len(stance) == 1:
            return [1.0]
        a, b = (data.oMf[self.sole[s]].translation[:2] for s in stance)
        d = b - a
        x = min(max(float((self.plan.zmp(t) - a) @ d / max(d @ d, 1e-12)), 0.0), 1.0)
        return [1.0 - x, x]

    def trunk_frames(self) -> list[int]:
        """Frames kept upright: the pelvis (root joint) and, if the model has one, the torso."""
        if not hasattr(self, "_trunk"):
            model = self.model
            frames = [model.getFrameId(model.names[1], pin.FrameType.JOINT)]
            torso = torso_frame(model)
            if torso is not None:
                frames.append(torso)
            self._trunk = frames
        return self._trunk


class HeldForces:
    """What :meth:`WalkingController.held_torques` holds from a solve to the next: the corner
    forces in their joints' axes (the welds keep those joints still), and the same packed for
    the compiled kernel (:meth:`~humanoid.dynamics.TreeDynamics.held`: the corners' points and
    forces, the welds' frames and anchors, the locks, the hinges' damper rows, the range rows
    held, the Baumgarte gains). The stance's part is packed once per stance, the rest at each
    solve.

    Args:
        model: The controller's model.
    """

    def __init__(self, model: pin.Model) -> None:
        self.model = model
        tree = TreeDynamics(model)
        self.tree = tree if tree.available else None
        self.wrenches = JointWrenches(model)
        self.packed: tuple[np.ndarray, np.ndarray] | None = None  # (ints, reals) for the kernel
        self._forces: tuple = ()  # (joints, local points, forces in the joints' axes)
        # (the welds, the corners' joints, their points, the corners by joint, the stance's
        # ints, reals and hinge rows)
        self._stance: tuple | None = None
        self._rows: tuple | None = None  # (the welds, their rows packed for the kernel)

    def hold(self, ctl: WalkingController, stance, welds, f, Jr, Jh_dv) -> None:
        """Keep a solve's corner forces ``f`` (k, 3, world axes, at ``ctl.data``'s placements)
        with the range rows ``Jr`` it held and its hinges' accelerations ``Jh_dv``."""
        if self._stance is None or self._stance[0] is not welds:
            joints = [j for s in stance for j in ctl._corner_joints[s]]
            local = np.concatenate([ctl._corner_local[s] for s in stance])
            groups = [(j, _run_of(np.flatnonzero(np.equal(joints, j))))
                      for j in dict.fromkeys(joints)]  # fmt: skip
            self._stance = (welds, joints, local, groups, *self._pack_stance(ctl, stance, welds))
        _, joints, local, groups, ints, fixed, hinges = self._stance
        f_local = np.empty_like(f)
        for j, on in groups:  # R^T f: the joints' axes
            f_local[on] = f[on] @ ctl.data.oMi[j].rotation
        self._forces = (joints, local, f_local)
        self.packed = None
        if ints is None:
            return
        ints = ints.copy()
        ints[3] = len(Jr)
        hinges[:, 3] = Jh_dv
        b = ctl.baumgarte
        damper = [b.alpha, b.beta, ctl.every / ctl.period, RANGE_TIME, 1e-12]
        reals = np.concatenate([np.hstack([local, f_local]).ravel(), fixed, hinges.ravel(),
                                np.ravel(Jr), damper])  # fmt: skip
        self.packed = (ints, reals)

    def _pack_stance(self, ctl: WalkingController, stance, welds) -> tuple:
        """The stance's part of the kernel's arrays: (ints: the counts, the corners' joints,
        the welds and locks (:func:`~humanoid.constraints.foot.packed_rows`), the hinges' rows;
        the welds' and locks' reals; the hinges' bounds and signs), or Nones if a constraint
        is neither a weld nor a lock."""
        model, ranges = self.model, ctl.ranges
        packed = packed_rows(model, [w for s in stance for w in welds[s]])
        if self.tree is None or packed is None:
            return None, None, None
        cints, fixed = packed
        joints = [j for s in stance for j in ctl._corner_joints[s]]
        nh = 2 * len(ranges.iq)
        ints = np.concatenate([
            [len(joints), len(cints) // 3, nh, 0, 0], joints, cints,
            np.column_stack([np.tile(ranges.iq, 2), np.tile(ranges.iv, 2)]).ravel(),
        ]).astype(np.int64)  # fmt: skip
        sign = np.repeat([1.0, -1.0], nh // 2)
        bounds = np.concatenate([ranges.lo, ranges.hi])
        return ints, fixed, np.column_stack([bounds, sign, sign, np.zeros(nh)])

    def weld_rows(self, ctl: WalkingController, q, v, stance, welds) -> tuple:
        """(J, gamma) of the stance's welds and locks at (q, v) (``ctl.data``'s kinematics
        there): the compiled kernel's (:meth:`~humanoid.dynamics.TreeDynamics.constraint_rows`),
        or :func:`~humanoid.constraints.solve.stack`'s."""
        held = [w for s in stance for w in welds[s]]
        if self.tree is not None:
            if self._rows is None or self._rows[0] is not welds:
                packed = packed_rows(self.model, held)
                rows = None if packed is None else self.tree.rows_of(packed, ctl.baumgarte)
                self._rows = (welds, rows)
            if self._rows[1] is not None:
                rows = self.tree.constraint_rows(q, v, self._rows[1])
                if rows is not None:
                    return rows
        return stack(self.model, ctl.data, held, v, ctl.baumgarte)

    def compiled(self, q, v, dv) -> np.ndarray | None:
        """The held torques from the kernel, or None (no kernel, or it declined)."""
        if self.packed is None or self.tree is None:
            return None
        tau = np.empty(self.model.nv)
        return tau if self.tree.held(q, v, dv, *self.packed, tau) == 0 else None

    def fext(self) -> pin.StdVec_Force:
        """The held forces as RNEA's external forces (Pinocchio's path)."""
        return self.wrenches.set_local(*self._forces)


def _run_of(index: np.ndarray) -> slice | np.ndarray:
    """``index`` as a slice when it is a run of consecutive integers (a view, not a gather)."""
    if len(index) and index[-1] - index[0] == len(index) - 1:
        return slice(int(index[0]), int(index[-1]) + 1)
    return index
