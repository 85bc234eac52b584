"""The bodies and scenes shipped with the package, found by name.

- **Bodies** (``bodies/*.urdf``): median adults written by the body builder
  (``adult_male``: 1.75 m, 75 kg; ``adult_female``: 1.62 m, 62 kg).
- **Scenes** (``scenes/*.toml``): ``standing``, ``push``, ``tumble``, ``collapse``, ``drop``,
  ``balance``, ``slide``.
- **Studies** (``studies/*.toml``, also in the repository's ``models/studies/``):
  ``push_standing``, ``walk_speed``, ``push_slice`` (``humanoid sweep NAME``).

Wherever a body is asked for (:func:`humanoid.load`, a scene's ``[body] urdf``, the CLI's
``--model``) a shipped body's name or an example-robot-data robot's name (``"talos"``) may
stand for a URDF path; wherever a scene is asked for, a shipped scene's name may stand for its
file.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["BODIES", "SCENES", "STUDIES", "body_names", "body_path", "scene_names", "scene_path",
           "study_names", "study_path"]  # fmt: skip

BODIES = Path(__file__).resolve().parent / "bodies"
SCENES = Path(__file__).resolve().parent / "scenes"
STUDIES = Path(__file__).resolve().parent / "studies"


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
