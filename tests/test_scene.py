"""Scenes: TOML <-> frozen dataclass, and clear errors for bad files."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from conftest import BODIES, SCENES

import humanoid as hm
from humanoid import BodyParameters
from humanoid.errors import SceneError
from humanoid.scene import Contact, Effects, Scene
from humanoid.simulation import Simulation, simulate

SCENE_FILES = sorted(SCENES.glob("*.toml"))
MALE = str(BODIES / "adult_male.urdf")


def test_shipped_scenes_exist_and_load():
    names = {p.stem for p in SCENE_FILES}
    assert {"tumble", "standing", "push", "collapse"} <= names
    for path in SCENE_FILES:
        scene = Scene.load(path)
        assert scene.name == path.stem
        assert scene.body in hm.data.body_names()  # a shipped body, by name


@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.stem)
def test_round_trip_through_toml(tmp_path, path):
    scene = Scene.load(path)
    out = scene.save(tmp_path / "copy.toml")
    again = Scene.load(out)
    assert again.replace(source=scene.source) == scene


def test_body_parameters_in_a_scene(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('duration = 0.1\n[body]\nheight = 1.6\nmass = 55\nsex = "female"\n')
    scene = Scene.load(p)
    assert scene.body == BodyParameters(1.6, 55.0, "female")
    again = Scene.load(scene.save(tmp_path / "t.toml"))
    assert again.body == scene.body


def _write(tmp_path, text: str) -> Path:
    p = tmp_path / "bad.toml"
    p.write_text(text + f'\n[body]\nurdf = "{MALE}"\n')
    return p


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("speed = 2\n", r"bad.toml: unknown key 'speed'; valid: .*duration"),
        ("[effects]\nwind = 3\n", r"bad.toml: \[effects\] unknown key 'wind'; valid: .*gravity"),
        ("dt = -0.001\n", r"bad.toml: dt: must be a finite number > 0, got -0.001"),
        ('dt = "fast"\n', r"bad.toml: dt: expected a number, got str 'fast'"),
        ("duration = 0.0\n", r"duration: must be a finite number > 0"),
        (
            'integrator = "leapfrog"\n',
            r"integrator: unknown integrator 'leapfrog': "
            r"must be euler, semi_implicit_euler, rk4 or adaptive",
        ),
        (
            '[[effects.contacts]]\nfoot = "left"\nmu = -0.5\n',
            r"effects.contacts\[0\].mu: friction coefficient must be >= 0, got -0.5",
        ),
        (
            '[[effects.contacts]]\nfoot = "middle"\n',
            r"effects.contacts\[0\].foot: must be 'left' or 'right', got 'middle'",
        ),
        (
            '[[effects.contacts]]\nfoot = "left"\ngrip = 1\n',
            r"\[effects.contacts\[0\]\] unknown key 'grip'",
        ),
        (
            '[[effects.pushes]]\nframe = "nose"\nforce = [1, 0, 0]\nstart = 0\nduration = 1\n',
            r"effects.pushes\[0\].frame: no frame 'nose' in the body; frames: .*thorax",
        ),
        (
            '[[effects.pushes]]\nframe = "thorax"\nforce = [1, 0]\nstart = 0\nduration = 1\n',
            r"effects.pushes\[0\].force: must be 3 finite numbers",
        ),
        ("[effects]\ngravity = [0, 0, nan]\n", r"effects.gravity\[2\]: must be a finite number"),
        ('[controller]\nkind = "posture"\n', r"controller: a posture controller needs"),
        ("[stabilisation]\nbaumgarte = 0.5\n", r"stabilisation.baumgarte: time constant"),
        (
            '[stabilisation]\nquaternions = "euler"\n',
            r"stabilisation.quaternions: unknown quaternion formulation .euler.: "
            r"must be lie or coordinates",
        ),
        ("[initial]\nconfiguration = [1.0, 2.0]\n", r"initial.configuration: needs nq = 49"),
        (
            "[initial]\nbase_velocity = [0, 0, 0, inf, 0, 0]\n",
            r"initial.base_velocity\[3\]: must be a finite number, got inf",
        ),
        ("dt = true\n", r"dt: expected a number, got bool"),
        # (planted, a check of the damping alone and a margin bound of 1 m passed the rest)
        ("[effects]\nsprings = -1.0\n", r"effects: damping and springs must be >= 0"),
        ("[effects.ground]\nmargin = 0.2\n", r"effects.ground.margin: must be in \(0, 0.1\] m"),
        ("= broken", r"bad.toml: not valid TOML"),
    ],
)
def test_bad_scenes_name_file_key_and_reason(tmp_path, text, message):
    """Its own fields when the scene loads; what needs the body (a frame's name, the size of
    the configuration) when a simulation sets it up on its body."""
    with pytest.raises(SceneError, match=message):
        Simulation(Scene.load(_write(tmp_path, text)))


def test_missing_scene_and_missing_body(tmp_path):
    with pytest.raises(SceneError, match="scene file not found"):
        Scene.load(tmp_path / "nope.toml")
    p = tmp_path / "s.toml"
    p.write_text('[body]\nurdf = "no_such_body.urdf"\n')
    with pytest.raises(SceneError, match=r"s.toml: body.urdf: URDF file not found"):
        Simulation(Scene.load(p))  # (a scene loads no body: its set-up does)
    p.write_text('[body]\nurdf = "x.urdf"\nheight = 1.7\n')
    with pytest.raises(SceneError, match="either urdf or height/mass/sex"):
        Scene.load(p)
    p.write_text("[body]\nheight = 7.0\nmass = 70\n")
    with pytest.raises(SceneError, match=r"\[body\] height must be in \[0.5, 2.5\]"):
        Scene.load(p)


def test_scene_is_frozen_and_validated_on_replace():
    scene = Scene(body=MALE)
    with pytest.raises(AttributeError):
        scene.dt = 0.1  # type: ignore[misc]
    with pytest.raises(SceneError, match="dt"):
        scene.replace(dt=0.0)
    with pytest.raises(SceneError, match="appears twice"):
        scene.replace(effects=Effects(contacts=(Contact("left"), Contact("left"))))
    assert math.isinf(Contact("left").end)


class BuildCounter:
    """Counts the bodies built (Pinocchio models parsed from a URDF's text)."""

    def __init__(self, monkeypatch) -> None:
        import pinocchio as pin

        self.n, original = 0, pin.buildModelFromXML

        def counted(*args, **kw):
            self.n += 1
            return original(*args, **kw)

        monkeypatch.setattr(pin, "buildModelFromXML", counted)


def test_a_scene_loads_no_body_and_a_run_builds_it_once(monkeypatch, tmp_path):
    """A scene is data: loading one builds nothing. A run builds its body once, from a
    file, from body parameters, and through ``humanoid simulate`` (it was built twice there:
    once to check the scene, once to run it)."""
    from humanoid.cli import main

    builds = BuildCounter(monkeypatch)
    scene = Scene.load("tumble").replace(duration=0.004)
    assert builds.n == 0
    assert simulate(scene, quiet=True).status == "completed"
    assert builds.n == 1
    p = tmp_path / "s.toml"
    p.write_text('duration = 0.004\n[body]\nheight = 1.6\nmass = 55\nsex = "female"\n')
    assert simulate(Scene.load(p), quiet=True).status == "completed"
    assert builds.n == 2
    out = tmp_path / "run.npz"
    assert main(["simulate", "tumble", "--duration", "0.004", "--quiet", "--output", str(out)]) == 0
    assert builds.n == 3
