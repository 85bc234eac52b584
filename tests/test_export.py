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
    out = tmp_path / "body.xml"
    assert main(["export", "human", "--mjcf", str(out)]) == 0
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.nv == 42
