"""Generated pathological walks: a recorded walk's joint angles changed as a pathology changes
them (used by tests/test_pathological.py and scripts/pathological.py)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def hemiparetic(h, t, q, forces, stiff=0.5, abduct=8.0, drop=8.0, slow=1.0, lift=0.0,
                hike=8.0):  # fmt: skip
    """A walk (t, q) of the toolkit's body ``h`` (its ball joints' quaternions) with its right swing
    made a stroke survivor's: the knee bends ``stiff`` (a fraction) less (a stiff knee), the ankle
    drops ``drop`` deg (a foot drop), the hip abducts ``abduct`` deg (circumduction) and flexes
    ``lift`` deg more, and the pelvis hikes ``hike`` deg on the right, turning about the left hip's
    centre (:func:`_hike`): the foot clears the floor the stiff knee would drag it through. The
    right swings are where ``forces`` (the right foot's ground force, (n, 3)) is under 20 N, runs
    and gaps under 0.1 s ignored, each weighted w by a raised cosine (0 at lift-off and touch-down,
    1 at mid-swing): the hike by sqrt(w), the knee and the abduction by w, the ankle by w^2. The
    knee bends most just after toe-off, where w is small: the swing's peak knee flexion falls from
    63 to 55 deg on the male body's walk (a mild stiff knee; a stiffer one would change the stance
    before toe-off too). Time is stretched ``slow`` times (not dynamically consistent: a slower
    walk is not the same walk slower). Returns (t, q, w)."""
    from humanoid.walking.gait import contact_runs

    em = h.fusion.euler_model
    qe = np.array([h.fusion.to_euler(x)[0] for x in q])
    # the swings: the foot unloaded for 0.1 s or more (a heel that touches the floor for a few
    # milliseconds and bounces off is still swinging; one that bounces in a stance, standing)
    w = np.zeros(len(t))
    for a, b in contact_runs(forces[:, 2] <= 20.0, t, 0.1):
        w[a:b] = 0.5 - 0.5 * np.cos(2 * np.pi * (np.arange(b - a) + 0.5) / (b - a))

    def col(name):
        return em.joints[em.getJointId(name)].idx_q

    knee, add, ankle = col("right_knee"), col("right_hip_adduction"), col("right_ankle_flexion")
    qe[:, col("right_hip_flexion")] += np.radians(lift) * w
    late = w**2  # the ankle dropped in mid-swing; the knee and the hike over the whole swing
    qe[:, knee] *= 1.0 - stiff * w
    qe[:, add] -= np.radians(abduct) * w
    qe[:, ankle] -= np.radians(drop) * late
    out = np.array([h.fusion.to_quaternion(x)[0] for x in qe])
    return t * slow, _hike(h, out, np.radians(hike) * np.sqrt(w)), w


def _hike(h, q, angles):
    """The pelvis turned about the left hip's centre by ``angles`` [rad] about the walking
    direction (x), its right side up (a hip hike), with the left thigh and the trunk kept as
    they were in the world: only the right leg goes up with the pelvis."""
    model = h.model
    data = model.createData()
    root = model.joints[1]
    keep = [model.getJointId(n) for n in ("left_hip", "lumbar")]
    out = q.copy()
    for k, (x, a) in enumerate(zip(q, angles, strict=True)):
        if a == 0.0:
            continue
        pin.forwardKinematics(model, data, x)
        centre = data.oMi[keep[0]].translation
        turn = pin.SE3(pin.rpy.rpyToMatrix(-a, 0.0, 0.0), np.zeros(3))
        turn.translation = centre - turn.rotation @ centre
        pelvis = turn * data.oMi[1]
        y = out[k]
        y[root.idx_q : root.idx_q + 7] = pin.SE3ToXYZQUAT(pelvis)
        for j in keep:  # the child's world rotation unchanged: R_j' = (R_pelvis' P)^T R_world
            jm = model.joints[j]
            local = (pelvis * model.jointPlacements[j]).rotation.T @ data.oMi[j].rotation
            y[jm.idx_q : jm.idx_q + 4] = pin.Quaternion(local).coeffs()
    return out
