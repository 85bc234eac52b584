"""A run's metadata: the typed record written to and read from its .npz, and the files of the
first layout (one flat JSON table) read as they were."""

from __future__ import annotations

import json

import numpy as np
import pytest

import humanoid as hm
from humanoid.run_metadata import FORMAT, RunMetadata


@pytest.fixture(scope="module")
def run():
    return hm.simulate(hm.Scene.load("tumble").replace(duration=0.02), quiet=True)


def test_a_run_saves_its_typed_record_and_reads_it_back(run, tmp_path):
    path = run.save(tmp_path / "run.npz")
    with np.load(path) as z:
        stored = json.loads(str(z["metadata"]))
    assert stored["format"] == FORMAT and stored["run"]["nq"] == run.q.shape[1]
    back = hm.Trajectory.load(path)
    assert back.metadata == json.loads(json.dumps(run.metadata))  # as the table went in
    with np.load(path) as z:
        meta = RunMetadata.from_npz(z)
    assert meta.status == "completed" and meta.nq == 49 and meta.nv == 41
    assert meta.joint_names[1] == "root_joint" and isinstance(meta.joint_names, tuple)
    assert isinstance(meta.steps, int) and isinstance(meta.wall_time, float)
    assert meta.scene["dt"] == meta.dt == run.metadata["dt"] and meta.extra == {}
    with pytest.raises(AttributeError):
        meta.status = "failed"  # frozen


def test_a_file_of_the_first_layout_reads_as_it_did(run, tmp_path):
    """A run saved before the record: the metadata a flat JSON table under ``metadata``."""
    old = dict(run.metadata) | {"gait": {"speed": 1.2}, "weight": 700.0}
    path = tmp_path / "old.npz"
    arrays = {"t": run.t, "q": run.q, "v": run.v, "tau": run.tau, "energy": run.energy,
              "residual": run.residual}  # fmt: skip
    arrays |= {f"force/{k}": a for k, a in run.forces.items()}
    np.savez_compressed(path, metadata=json.dumps(old), **arrays)
    back = hm.Trajectory.load(path)
    assert back.metadata == json.loads(json.dumps(old))
    assert back.status == "completed" and np.array_equal(back.q, run.q)
    with np.load(path) as z:
        meta = RunMetadata.from_npz(z)
    assert meta.extra == {"gait": {"speed": 1.2}, "weight": 700.0} and meta.nv == 41
    # saved again, it is written in the new layout, the walk's keys among the extras
    again = hm.Trajectory.load(back.save(tmp_path / "again.npz"))
    assert again.metadata == back.metadata


def test_extras_and_nulls_travel_as_they_are(tmp_path):
    table = {"model": "x.urdf", "status": "completed", "message": None, "footsteps": [[1, 2]]}
    meta = RunMetadata.from_dict(table)
    assert meta.model == "x.urdf" and meta.message is None and meta.nq is None
    assert meta.as_dict() == table
    with np.load(_npz(tmp_path, meta.to_npz())) as z:
        assert RunMetadata.from_npz(z).as_dict() == table


def _npz(tmp_path, arrays):
    path = tmp_path / "m.npz"
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize(
    "text, message",
    [
        ('{"nq": "x"}', r"'nq' is str 'x', not int"),
        ('{"nq": true}', r"'nq' is bool True, not int"),
        ('{"dt": "1e-3"}', r"'dt' is str '1e-3', not float"),
        ('{"joint_names": "root"}', r"'joint_names' is str 'root', not a sequence"),
        ('{"scene": []}', r"'scene' is list \[\], not dict"),
        ("[]", "its metadata is not a table"),
        ("{", "its metadata is not JSON"),
        ('{"format": 7, "run": {}}', "metadata of format 7; this version reads formats 1 and 2"),
        ('{"format": 2, "run": {}, "extra": []}', "'extra' is not a table"),
    ],
)
def test_metadata_of_the_wrong_type_is_refused_naming_the_key(tmp_path, text, message):
    with np.load(_npz(tmp_path, {"metadata": np.array(text)})) as z:
        with pytest.raises(hm.TrajectoryError, match=message):
            RunMetadata.from_npz(z, "run.npz")
    with np.load(_npz(tmp_path, {"other": np.zeros(1)})) as z:
        with pytest.raises(hm.TrajectoryError, match="has no metadata"):
            RunMetadata.from_npz(z)


def test_a_saved_run_with_bad_metadata_is_a_trajectory_error(run, tmp_path):
    path = run.save(tmp_path / "run.npz")
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["metadata"] = np.array(json.dumps({"format": 2, "run": {"nv": 3.5}}))
    np.savez(path, **arrays)
    with pytest.raises(hm.TrajectoryError, match=r"trajectory .*run.npz: its metadata's 'nv'"):
        hm.Trajectory.load(path)
