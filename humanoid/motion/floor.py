"""The floor a motion was recorded on, as it is: a plane fitted to the feet's stance points.

A lab floor is rarely the plane z = 0 of the motion capture's axes: it may be tilted by a
degree or two, or sit a few millimetres off. :func:`fit_floor` finds it from the motion alone:
the sole points (:meth:`~humanoid.model.Humanoid.sole_points`) in their stance phases, found
by stillness (no assumption on where the floor is), a robust least-squares plane through them.
:func:`~humanoid.motion.inverse_dynamics.estimate_loads` and
:func:`~humanoid.motion.inverse_dynamics.contact_schedule` take the result as ``floor``.

On a treadmill the standing foot is not still: it moves back with the belt. The belt's velocity
(:func:`belt_velocity`: the median velocity of the lowest sole point, zero over ground) is found
first and stillness is judged relative to it. :meth:`Floor.onto` turns a motion into the
floor's own frame, level and moving with its belt: a treadmill walk becomes the walk over
ground it is (the physics is the same in any frame moving at a constant velocity), which
forward tracking (:func:`~humanoid.motion.tracking.track`) can follow on a level floor under
gravity turned as the floor is (:meth:`Floor.gravity`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..model import SIDES
from .storage import MotionFileError

__all__ = [
    "LEVEL",
    "Floor",
    "ResidualWarning",
    "belt_velocity",
    "fit_floor",
    "residual_check",
    "stance_points",
]

# [m/s] a lowest sole point moving faster than this, over most of the motion, is on a belt: over
# ground it is still (under 0.1 m/s); treadmills run from about 0.4 m/s
BELT_SPEED = 0.25


class ResidualWarning(UserWarning):
    """The root (pelvis) residual force of an inverse dynamics is large (over 10 % of body
    weight RMS): the loads do not explain the motion somewhere."""


@dataclass(frozen=True)
class Floor:
    """A floor plane in world axes.

    Attributes:
        normal: Its unit normal (3,), pointing up (positive z).
        height: Its height at the world origin (x = y = 0) [m].
        tilt_x_deg, tilt_y_deg: Its tilt [deg]: the normal is the world's z axis rotated about
            x by ``tilt_x_deg``, then about y by ``tilt_y_deg`` (a floor rising along +x has a
            negative tilt about y; along +y, a positive tilt about x).
        points_used: How many stance samples of sole points it was fitted to (inliers).
        rms: The RMS distance of those points from it [m].
        belt: A treadmill belt's velocity (3,) [m/s, world axes, along the floor]; zero over
            ground.
    """

    normal: tuple[float, float, float]
    height: float
    tilt_x_deg: float = 0.0
    tilt_y_deg: float = 0.0
    points_used: int = 0
    rms: float = 0.0
    belt: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @classmethod
    def from_normal(cls, normal, height: float, points_used: int = 0, rms: float = 0.0,
                    belt=(0.0, 0.0, 0.0)) -> Floor:  # fmt: skip
        """The floor of a normal (any length, made unit and upward) and a height at the origin
        [m], its tilts computed; ``belt`` [m/s] is projected onto it."""
        n = np.asarray(normal, dtype=float).reshape(3)
        n = n / np.linalg.norm(n) * (1.0 if n[2] >= 0 else -1.0)
        tx = math.degrees(math.atan2(-n[1], math.hypot(n[0], n[2])))
        ty = math.degrees(math.atan2(n[0], n[2]))
        b = np.asarray(belt, dtype=float).reshape(3)
        b = b - (b @ n) * n
        normal3 = (float(n[0]), float(n[1]), float(n[2]))
        belt3 = (float(b[0]), float(b[1]), float(b[2]))
        return cls(normal3, float(height), tx, ty, int(points_used), float(rms), belt3)

    @property
    def speed(self) -> float:
        """The belt's speed [m/s] (0 over ground)."""
        return float(np.linalg.norm(self.belt))

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3): world axes to the floor's (its third column the normal): ``R_y R_x``."""
        return pin.rpy.rpyToMatrix(math.radians(self.tilt_x_deg), math.radians(self.tilt_y_deg),
                                   0.0)  # fmt: skip

    def above(self, points) -> np.ndarray:
        """The height of ``points`` (..., 3) [m, world] above the floor, along its normal [m]
        (negative below it)."""
        p = np.asarray(points, dtype=float)
        return (p - np.array([0.0, 0.0, self.height])) @ np.asarray(self.normal)

    def centre_of_pressure(self, wrench) -> tuple[np.ndarray, np.ndarray]:
        """A wrench about the world origin (n, 6) as its centre of pressure on the floor and
        the free moment (along the normal) left there: (point (n, 3) [m], torque (n, 3) [N m]);
        where the force along the normal is under 1e-9 N, the point is the origin and the
        torque the whole moment."""
        from ..dynamics import centre_of_pressure

        w = np.asarray(wrench, dtype=float).reshape(-1, 6)
        f, m = w[:, :3], w[:, 3:]
        p0 = np.array([0.0, 0.0, self.height])
        R = self.rotation  # (the floor's axes, its normal the third)
        m0 = m - np.cross(p0, f)  # about a point of the floor, then in the floor's axes
        c = centre_of_pressure(np.hstack([f @ R, m0 @ R]))
        ok = np.isfinite(c[:, 0])
        point = np.where(ok[:, None], p0 + np.where(ok[:, None], c, 0.0) @ R[:, :2].T, 0.0)
        torque = m - np.cross(point, f)
        return point, torque

    def gravity(self, gravity=(0.0, 0.0, -9.81)) -> np.ndarray:
        """World ``gravity`` (3,) [m/s^2] in the floor's axes (:meth:`onto`)."""
        return self.rotation.T @ np.asarray(gravity, dtype=float)

    def onto(self, model, time, q) -> np.ndarray:
        """The configurations ``q`` (n, nq) at ``time`` (n,) [s] of a free-flyer ``model`` in
        the floor's frame: its plane is z = 0 and level (the floor's axes, :attr:`rotation`),
        and the frame moves with the belt from ``time[0]`` on (a treadmill walk becomes a walk
        over ground; physics is the same in it, under :meth:`gravity`). Only the root's
        placement changes."""
        if "FreeFlyer" not in model.joints[1].shortname():
            raise MotionFileError("a floor's frame needs a body with a free-flyer root")
        time = np.asarray(time, dtype=float).reshape(-1)
        out = np.array(q, dtype=float, copy=True)
        R = self.rotation
        moved = np.outer(time - time[0], np.asarray(self.belt)) + np.array([0, 0, self.height])
        out[:, :3] = (out[:, :3] - moved) @ R  # R^T (p - o) per row
        turn = pin.Quaternion(R.T)
        for row in out:
            quat = turn * pin.Quaternion(row[6], row[3], row[4], row[5])
            row[3:7] = quat.coeffs()  # x, y, z, w
        return out

    def summary(self) -> str:
        """One line: "tilt 1.98 deg about y, -0.03 about x, 12.0 mm at the origin (fitted to
        412 stance points, 1.1 mm RMS)", and a treadmill's "; belt 1.15 m/s"."""
        belt = f"; belt {self.speed:.2f} m/s" if self.speed > 0.0 else ""
        return (f"tilt {self.tilt_y_deg:.2f} deg about y, {self.tilt_x_deg:.2f} about x, "
                f"{self.height * 1e3:.1f} mm at the origin (fitted to {self.points_used} stance "
                f"points, {self.rms * 1e3:.1f} mm RMS){belt}")  # fmt: skip


# the level floor z = 0, without a belt
LEVEL = Floor((0.0, 0.0, 1.0), 0.0)


def _sole_positions(h, q) -> np.ndarray:
    """Every sole point's world position in every sample, (n, points, 3) [m], both feet's."""
    model = h.model
    data = model.createData()
    pts = {s: h.sole_points(s) for s in SIDES}
    out = np.empty((len(q), sum(len(p) for p in pts.values()), 3))
    for i, qi in enumerate(q):
        pin.framesForwardKinematics(model, data, qi)
        out[i] = np.concatenate(
            [pts[s] @ data.oMf[h.sole_id(s)].rotation.T + data.oMf[h.sole_id(s)].translation
             for s in SIDES]
        )  # fmt: skip
    return out


def _sole_velocities(h, time, q, cutoff: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Every sole point's position and velocity in every sample, (n, points, 3) each, the
    velocities from the positions low-passed at ``cutoff`` [Hz] (None: not filtered)."""
    from .inverse_dynamics import lowpass

    P = _sole_positions(h, np.asarray(q, dtype=float))
    if len(time) < 2:
        return P, np.zeros_like(P)
    flat = P.reshape(len(time), -1)
    rate = (len(time) - 1) / (time[-1] - time[0])
    if cutoff is not None and len(time) > 12 and cutoff < rate / 2.0:
        flat = lowpass(flat, rate, cutoff)
    return P, np.gradient(flat, time, axis=0).reshape(P.shape)


def belt_velocity(h, time, q, cutoff: float | None = 6.0) -> np.ndarray:
    """A treadmill belt's velocity (3,) [m/s, world axes] under a motion: the median velocity of
    the lowest sole point of each sample (in a walk one foot always stands), zero if that is
    under ``BELT_SPEED`` (0.25 m/s: over ground) or if the body goes along with it (its root's
    mean velocity over half of it: a body carried, not walking on a belt, which keeps the
    walker in place)."""
    time = np.asarray(time, dtype=float).reshape(-1)
    P, V = _sole_velocities(h, time, q, cutoff)
    if len(time) < 3:
        return np.zeros(3)
    low = np.argmin(P[:, :, 2], axis=1)
    v = np.median(V[np.arange(len(time)), low], axis=0)
    q = np.asarray(q, dtype=float)
    root = (q[-1, :3] - q[0, :3]) / (time[-1] - time[0])
    speed = float(np.linalg.norm(v[:2]))
    if speed <= BELT_SPEED or float(np.linalg.norm(root[:2])) > 0.5 * speed:
        return np.zeros(3)
    return v


def stance_points(h, time, q, speed: float = 0.1, release: float = 0.2,
                  duration: float = 0.05, cutoff: float | None = 6.0,
                  belt=(0.0, 0.0, 0.0)) -> np.ndarray:  # fmt: skip
    """The sole points' positions in their stances: (m, 3) [m, world], every sample at which a
    sole point is still, wherever it is (no floor height is assumed).

    A point is still from when its speed [m/s] falls under ``speed`` until it rises over
    ``release`` (hysteresis), for at least ``duration`` [s]; speeds are from the positions
    low-passed at ``cutoff`` [Hz] (None: not filtered), then differentiated, and relative to a
    treadmill's ``belt`` velocity (3,) [m/s] (:func:`belt_velocity`; a standing foot moves
    with the belt).
    """
    time = np.asarray(time, dtype=float).reshape(-1)
    P, V = _sole_velocities(h, time, q, cutoff)
    if len(time) < 2:
        return P.reshape(-1, 3)[:0]
    rate = (len(time) - 1) / (time[-1] - time[0])
    fast = np.linalg.norm(V - np.asarray(belt, dtype=float), axis=2)
    still = np.zeros(fast.shape, dtype=bool)
    state = fast[0] < speed
    for i in range(len(time)):
        state = np.where(state, fast[i] < release, fast[i] < speed)
        still[i] = state
    shortest = max(1, int(round(duration * rate)))
    for k in range(still.shape[1]):  # drop runs shorter than ``duration``
        col = still[:, k]
        edges = np.flatnonzero(np.diff(np.concatenate([[0], col.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if b - a < shortest:
                col[a:b] = False
    return P[still]


def _plane(points: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The weighted total-least-squares plane: (its unit normal, a point on it, the singular
    values of the weighted centred points)."""
    w = weights / weights.sum()
    c = w @ points
    _, s, vt = np.linalg.svd((points - c) * np.sqrt(w)[:, None], full_matrices=False)
    return vt[2], c, s


def fit_floor(h, time, q, *, speed: float = 0.1, release: float = 0.2, duration: float = 0.05,
              cutoff: float | None = 6.0, iterations: int = 20, belt=None) -> Floor:  # fmt: skip
    """The floor a motion stands on: a plane fitted to the sole points in their stances
    (:func:`stance_points`, with ``speed``, ``release`` [m/s], ``duration`` [s], ``cutoff``
    [Hz]) by iteratively reweighted total least squares (Tukey's biweight on the distances to
    the plane, scaled by their median absolute deviation, at least 1 mm): points off the floor
    (a foot held still in the air, a heel resting on a step) get no weight.

    Args:
        h: The :class:`~humanoid.model.Humanoid`. time: (n,) [s]. q: (n, nq) configurations.
        belt: A treadmill's belt velocity (3,) [m/s, world axes], or its speed (along the
            motion's backward direction, -x); default None: :func:`belt_velocity` of the
            motion (zero over ground).

    Returns:
        The :class:`Floor` (world axes).

    Raises:
        MotionFileError: fewer than 3 stance points, or all of them on a line (spread under
            1 cm across it): no plane is defined.
    """
    if belt is None:
        belt = belt_velocity(h, time, q, cutoff)
    elif np.ndim(belt) == 0:
        belt = np.array([-float(belt), 0.0, 0.0])
    P = stance_points(h, time, q, speed=speed, release=release, duration=duration,
                      cutoff=cutoff, belt=belt)  # fmt: skip
    if len(P) < 3:
        raise MotionFileError(
            f"the floor needs at least 3 stance points (sole points still for {duration:g} s "
            f"or more), the motion has {len(P)}"
        )
    weights = np.ones(len(P))
    for _ in range(iterations):
        normal, centre, s = _plane(P, weights)
        if s[1] < 0.01:  # RMS spread across the points' line [m]
            raise MotionFileError(
                f"the motion's {len(P)} stance points lie on a line (spread {s[1] * 1e3:.1f} mm "
                "across it): no floor plane is defined"
            )
        d = (P - centre) @ normal
        scale = max(1.4826 * float(np.median(np.abs(d - np.median(d)))), 1e-3)
        u = d / (4.685 * scale)
        new = np.where(np.abs(u) < 1.0, (1.0 - u**2) ** 2, 0.0)
        if np.allclose(new, weights, atol=1e-6):
            break
        weights = new
    normal = normal if normal[2] >= 0 else -normal
    inliers = weights > 0
    rms = float(np.sqrt(np.mean(((P[inliers] - centre) @ normal) ** 2)))
    height = float(centre @ normal / normal[2])  # where the plane crosses x = y = 0
    return Floor.from_normal(normal, height, int(inliers.sum()), rms, belt)


def residual_check(time, residual_force, weight: float, loads=(), floor: Floor | None = None,
                   limit: float = 0.10) -> str | None:  # fmt: skip
    """A warning's text when the root residual force's RMS exceeds ``limit`` times the body's
    ``weight`` [N], else None: the time span of the worst frames (the run of frames over
    ``limit`` around the largest) and the likely cause (no load there: no foot on the floor or
    loads missing; a tilted ``floor``; else loads that miss part of the motion).

    Args:
        time: (n,) [s]. residual_force: (n, 3) [N, world]. loads: The
            :class:`~humanoid.motion.loads.Load` s applied. floor: The floor they stood on.
    """
    time = np.asarray(time, dtype=float)
    rf = np.linalg.norm(np.asarray(residual_force, dtype=float).reshape(-1, 3), axis=1)
    rms = float(np.sqrt(np.mean(rf**2)))
    if rms <= limit * weight:
        return None
    worst = int(np.argmax(rf))
    over = rf > limit * weight
    a = b = worst
    while a > 0 and over[a - 1]:
        a -= 1
    while b < len(rf) - 1 and over[b + 1]:
        b += 1
    span = slice(a, b + 1)
    carried = np.zeros(b + 1 - a)
    for x in loads:
        carried += np.interp(time[span], x.time, x.force[:, 2], left=0.0, right=0.0)
    if np.mean(carried) < 0.05 * weight:
        cause = ("no load on the feet there: no foot on the floor (the feet above the floor the "
                 "loads were estimated on?) or loads missing")  # fmt: skip
    elif floor is not None and max(abs(floor.tilt_x_deg), abs(floor.tilt_y_deg)) > 0.5:
        cause = f"a floor not level ({floor.summary()})"
    else:
        cause = "loads missing or misplaced (a foot on something other than the floor?)"
    return (f"the root residual force is {rms:.0f} N RMS ({rms / weight * 100:.0f} % of body "
            f"weight, over {limit * 100:.0f} %), worst at {time[a]:.2f}-{time[b]:.2f} s "
            f"({rf[worst]:.0f} N at {time[worst]:.2f} s): likely {cause}")  # fmt: skip
