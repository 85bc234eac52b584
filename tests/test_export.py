"""MJCF export: the MuJoCo model has the same mechanics as the Pinocchio one."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import get_model, random_state

from humanoid.cli import main
from humanoid.export import mujoco_state, pinocchio_state, to_mjcf

mujoco = pytest.importorskip("mujoco")  # in the test extras: installed by make test


@pytest.mark.parametrize(("name", "mode"), [("male", "quaternion"), ("female", "quaternion"),
                                            ("human", "quaternion"), ("human", "euler"),
                                            ("male", "euler")])  # fmt: skip
def test_mujoco_model_has_the_same_mechanics(name, mode):
    """Mass, energies and accelerations agree on seeded random states (massless hinge links
    merged into multi-joint bodies, which MuJoCo requires)."""
    h = get_model(name, mode)
    m = mujoco.MjModel.from_xml_string(to_mjcf(h))
    d = mujoco.MjData(m)
    assert m.nv == h.nv and m.nq == h.nq
    assert m.body_mass.sum() == pytest.approx(h.mass, rel=1e-12)
    rng = np.random.default_rng(50)
    pdata = h.model.createData()
    for _ in range(3):
        q, v = random_state(h, rng)
        d.qpos[:], d.qvel[:] = mujoco_state(h, m, q, v)
        mujoco.mj_forward(m, d)
        mujoco.mj_energyPos(m, d)
        mujoco.mj_energyVel(m, d)
        ke = pin.computeKineticEnergy(h.model, pdata, q, v)
        pe = pin.computePotentialEnergy(h.model, pdata, q)
        assert d.energy[1] == pytest.approx(ke, rel=1e-10)
        assert d.energy[0] == pytest.approx(pe, rel=1e-10)
        a = pin.aba(h.model, pdata, q, v, np.zeros(h.nv))
        # joint and angular accelerations share their coordinates (the base's linear part is
        # in world axes in MuJoCo)
        assert np.abs(d.qacc[3:] - a[3:]).max() < 1e-8 * max(1.0, np.abs(a).max())
        q2, v2 = pinocchio_state(h, m, d.qpos, d.qvel)
        assert np.abs(pin.difference(h.model, q, q2)).max() < 1e-12
        assert np.abs(v2 - v).max() < 1e-12


def test_export_command(tmp_path, capsys):
    """``humanoid export --mjcf`` writes a model to simulate: a floor, every degree of freedom
    but the root's with a motor, every joint limited, the contact parameters written out."""
    out = tmp_path / "body.xml"
    assert main(["export", "human", "--mjcf", str(out), "--mu", "0.7"]) == 0
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.nv == 42 and m.nu == 36
    assert m.jnt_limited[1:].all()  # (the free joint has none)
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    assert floor >= 0 and m.geom_friction[floor, 0] == pytest.approx(0.7)
    assert (m.geom_contype[m.geom_bodyid > 0] == 1).any()
    text = out.read_text()
    assert 'solref="0.02 1"' in text and 'solimp="0.9 0.95 0.001"' in text
    assert "each with a motor; joint ranges on; a floor (friction 0.7)" in capsys.readouterr().out
    assert main(["export", "human", "--mjcf", str(out), "--mu", "nan"]) == 2
    assert main(["export", "human", "--mjcf", str(out), "--no-floor"]) == 0
    assert "floor" not in out.read_text()


def test_motors_act_on_their_joints():
    """A hinge's motor's unit control is 1 N m on its joint; a ball joint's three on its own
    x, y and z axes (a planted gear would move another coordinate)."""
    h = get_model("male", "quaternion")
    m = mujoco.MjModel.from_xml_string(to_mjcf(h, motors=True))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for a in range(m.nu):
        d.ctrl[:] = 0.0
        d.ctrl[a] = 1.0
        mujoco.mj_fwdActuation(m, d)
        dof = m.jnt_dofadr[m.actuator_trnid[a, 0]]
        expected = np.zeros(m.nv)
        k = 0 if m.jnt_type[m.actuator_trnid[a, 0]] != mujoco.mjtJoint.mjJNT_BALL else (
            int(np.flatnonzero(m.actuator_gear[a, :3])[0]))  # fmt: skip
        expected[dof + k] = 1.0
        np.testing.assert_allclose(d.qfrc_actuator, expected, atol=1e-12)


@pytest.mark.parametrize("name", ["collapse", "drop"])
def test_the_exported_body_falls_in_mujoco_as_ours(name, tmp_path):
    """The shipped fall scenes, 2.5 s from the same state: ours (rigid contact, the ranges as
    constraints) and MuJoCo on ``write_mjcf``'s file (its soft contacts, the ball joints' cone
    limits) end within 15 % of the energy the fall dissipated of each other (measured:
    collapse 151 and 162 J of 726, drop 113 and 104 J of 1094); ours penetrates under
    0.1 mm, MuJoCo's soft contact 24-27 mm (stated in the README's chart, not a defect)."""
    from humanoid.export import StateMap, write_mjcf
    from humanoid.scene import Scene
    from humanoid.simulation import Simulation

    scene = Scene.load(name).replace(duration=2.5)
    sim = Simulation(scene)
    traj = sim.run(quiet=True)
    h = sim.h
    data = h.model.createData()

    def energy(q, v):
        return (pin.computeKineticEnergy(h.model, data, q, v)
                + pin.computePotentialEnergy(h.model, data, q))  # fmt: skip

    path = write_mjcf(h, tmp_path / "body.xml", mu=scene.effects.ground.mu,
                      timestep=scene.dt, damping=scene.effects.damping)  # fmt: skip
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    states = StateMap(h, m)
    d.qpos[:], d.qvel[:] = states.to_mujoco(sim.q0, sim.v0)
    depth = 0.0
    for _ in range(int(round(scene.duration / scene.dt))):
        mujoco.mj_step(m, d)
        if d.ncon:
            depth = max(depth, -float(d.contact.dist[: d.ncon].min()))
    start, ours = energy(traj.q[0], traj.v[0]), energy(traj.q[-1], traj.v[-1])
    theirs = energy(*states.to_pinocchio(d.qpos, d.qvel))
    assert abs(theirs - ours) < 0.15 * (start - ours), (start, ours, theirs)
    assert traj.metadata["max_penetration"] < 1e-4
    assert 0.005 < depth < 0.04, depth


@pytest.mark.parametrize("ground", [None, 0.0])
def test_the_exported_boxes_are_the_bodys_half_sizes(ground):
    """MuJoCo's box size is its half-sizes, as Pinocchio's halfSide: the male body's boxes
    (visual, or the collision boxes with a ground) come back the same from MuJoCo's own
    parse (a planted export of the full sizes passed the mechanics and the fall)."""
    h = get_model("male", "quaternion")
    m = mujoco.MjModel.from_xml_string(to_mjcf(h, ground=ground))
    model = h.visual_model if ground is None else h.collision_model
    ours = sorted(tuple(np.round(np.sort(g.geometry.halfSide), 9)) for g in model.geometryObjects
                  if type(g.geometry).__name__ == "Box")  # fmt: skip
    theirs = sorted(tuple(np.round(np.sort(m.geom_size[i]), 9)) for i in range(m.ngeom)
                    if m.geom_type[i] == mujoco.mjtGeom.mjGEOM_BOX)  # fmt: skip
    assert ours and theirs == ours
