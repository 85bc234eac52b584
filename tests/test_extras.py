"""The optional extras: without one, the feature that needs it says which ``pip install`` brings
it, in one line (a typed error); ``import humanoid`` and the core never import them."""

from __future__ import annotations

import subprocess
import sys

import pytest

from humanoid.errors import EXTRAS, HumanoidError, MissingExtra, require


def test_require_names_the_extra_to_install():
    with pytest.raises(MissingExtra, match=r"a thing needs no_such_mod, which is not installed"):
        require("no_such_mod.sub", "a thing")
    with pytest.raises(ImportError):  # (also an ImportError, and a HumanoidError)
        require("no_such_mod", "a thing")
    assert issubclass(MissingExtra, HumanoidError)
    assert require("numpy.linalg", "x").__name__ == "numpy.linalg"


@pytest.mark.parametrize(("module", "extra"), sorted(EXTRAS.items()))
def test_each_extra_is_in_pyproject(module, extra):
    import tomllib
    from pathlib import Path

    meta = tomllib.loads((Path(__file__).parent.parent / "pyproject.toml").read_text())
    extras = meta["project"]["optional-dependencies"]

    def names(dep):  # ("dask[distributed]>=2024.1" installs dask and distributed)
        return module == dep.split(">")[0].split("[")[0] or f"[{module}]" in dep

    assert any(names(dep) for dep in extras[extra]), (module, extras[extra])
    assert not any(names(dep) for dep in meta["project"]["dependencies"])


def test_a_c3d_without_ezc3d_says_which_extra(monkeypatch):
    from humanoid.data import trial_path
    from humanoid.motion.c3d import read_plates
    from humanoid.motion.markers import read_c3d

    monkeypatch.setitem(sys.modules, "ezc3d", None)  # (its import now fails)
    for read in (read_c3d, read_plates):
        with pytest.raises(MissingExtra, match=r"pip install 'humanoid-toolkit\[c3d\]'"):
            read(trial_path("walking5.c3d"))


def test_a_study_table_without_pyarrow_says_which_extra(monkeypatch, tmp_path):
    from humanoid.study.store import read_table

    (tmp_path / "results.parquet").write_bytes(b"")
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(MissingExtra, match=r"pip install 'humanoid-toolkit\[studies\]'"):
        read_table(tmp_path / "results.parquet")


def test_import_humanoid_and_its_cli_load_no_extra():
    extras = sorted(EXTRAS)
    code = ("import sys, humanoid, humanoid.cli, humanoid.motion.commands, humanoid.study;"
            f"print(sorted({{m.split('.')[0] for m in sys.modules}} & set({extras})))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout
