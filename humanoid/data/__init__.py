"""The bodies and scenes shipped with the package, found by name.

- **Bodies** (``bodies/*.urdf``): median adults written by the body builder
  (``adult_male``: 1.75 m, 75 kg; ``adult_female``: 1.62 m, 62 kg).
- **Scenes** (``scenes/*.toml``): ``standing``, ``push``, ``tumble``, ``collapse``, ``drop``,
  ``balance``, ``slide``.
- **Studies** (``studies/*.toml``, also in the repository's ``models/studies/``):
  ``push_standing``, ``walk_speed``, ``push_slice`` (``humanoid sweep NAME``).
- **Trials** (``trials/``): real recordings from OpenSim (Apache-2.0, see its README.md):
  gait2354's ``subject01`` (``subject01_static.trc``, ``subject01_walk1.trc``,
  ``subject01_walk1_grf.mot`` and its ``.xml``; 72.6 kg) and the Vicon ``walking5.c3d`` (two
  force plates).

Wherever a body is asked for (:func:`humanoid.load`, a scene's ``[body] urdf``, the CLI's
``--model``) a shipped body's name or an example-robot-data robot's name (``"talos"``) may
stand for a URDF path; wherever a scene is asked for, a shipped scene's name may stand for its
file.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["BODIES", "SCENES", "STUDIES", "TRIALS", "body_names", "body_path", "scene_names",
           "scene_path", "study_names", "study_path", "trial_names", "trial_path"]  # fmt: skip

BODIES = Path(__file__).resolve().parent / "bodies"
SCENES = Path(__file__).resolve().parent / "scenes"
STUDIES = Path(__file__).resolve().parent / "studies"
TRIALS = Path(__file__).resolve().parent / "trials"
_TRIAL_SUFFIXES = (".trc", ".mot", ".xml", ".c3d")


def body_names() -> tuple[str, ...]:
    """Names of the shipped bodies."""
    return tuple(sorted(p.stem for p in BODIES.glob("*.urdf")))


def scene_names() -> tuple[str, ...]:
    """Names of the shipped scenes."""
    return tuple(sorted(p.stem for p in SCENES.glob("*.toml")))


def body_path(name: str) -> Path | None:
    """The URDF file of a shipped body, or None if no shipped body has that name."""
    return BODIES / f"{name}.urdf" if name in body_names() else None


def scene_path(name: str) -> Path | None:
    """The TOML file of a shipped scene, or None if no shipped scene has that name."""
    return SCENES / f"{name}.toml" if name in scene_names() else None


def study_names() -> tuple[str, ...]:
    """Names of the shipped studies."""
    return tuple(sorted(p.stem for p in STUDIES.glob("*.toml")))


def study_path(name: str) -> Path | None:
    """The TOML file of a shipped study, or None if no shipped study has that name."""
    return STUDIES / f"{name}.toml" if name in study_names() else None


def trial_names() -> tuple[str, ...]:
    """The files of the shipped trials (``subject01_walk1.trc`` ...)."""
    return tuple(sorted(p.name for p in TRIALS.iterdir() if p.suffix in _TRIAL_SUFFIXES))


def trial_path(name: str) -> Path | None:
    """A shipped trial's file, or None if no shipped trial has that name."""
    return TRIALS / name if name in trial_names() else None
