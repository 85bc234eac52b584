"""A study file: what runs, what varies between them, what each run keeps.

A study is a TOML file (shipped ones in ``models/studies/``)::

    [study]
    name = "push-standing"      # names the output folder (results/studies/NAME)
    run = "scene"               # scene (a scene file, pushed or not) | walk (on the ground)
    scene = "balance"           # run = scene: a shipped scene or a file next to this one
    keep = "summary"            # summary | trajectory (each run's .npz beside the table)
    seed = 0                    # the samples' seed

    [set]                       # the same in every run
    "scene.duration" = 3.0
    "push.frame" = "thorax"
    "push.start" = 0.5
    "push.duration" = 0.2

    [grid]                      # every combination of these
    "body.height" = [1.55, 1.75, 1.95]      # [m]
    "body.bmi" = [20.0, 25.0]               # [kg/m^2] (or body.mass [kg])
    "body.sex" = ["male", "female"]
    "push.fraction" = [0.1, 0.2, 0.3]       # of body weight (or push.force [N])

    [sample]                    # n random draws (seeded), each combined with the grid
    n = 20
    "body.height" = { normal = [1.70, 0.09], clip = [1.45, 2.0] }
    "body.bmi" = { uniform = [19.0, 30.0] }
    "body.sex" = { choice = ["male", "female"] }

    [figure]                    # the study's main result (see humanoid.study.figures)
    kind = "threshold"          # threshold: the largest value up to which a column is true
    value = "push_force"        #   in every run, per group (the largest push survived)
    where = "survived"
    x = "body.height"
    series = "body.bmi"
    panels = "body.sex"

Parameters (keys of ``set``, ``grid`` and ``sample``):

- ``body.height`` [m], ``body.mass`` [kg] or ``body.bmi`` [kg/m^2], ``body.sex``: a de Leva
  body built for the run (all of height, sex and mass or BMI, or none: the base's body);
  ``body.toes`` (default true; false: one-piece feet);
- ``push.force`` [N] or ``push.fraction`` [body weights], ``push.direction`` (forward,
  backward, left, right, or an angle in degrees from forward towards the left),
  ``push.frame``, ``push.start`` [s], ``push.duration`` [s]: one horizontal push;
- ``scene.KEY``: any key of the scene file, dotted (``scene.dt``, ``scene.integrator``,
  ``scene.controller.frequency``, ``scene.effects.ground.mu``), run = scene only;
- ``walk.speed`` [m/s] or ``walk.speed_ratio`` (times the body's free speed),
  ``walk.steps``, ``walk.dt`` [s], ``walk.mu``: the ground walk (run = walk only).

Every mistake raises :class:`~humanoid.errors.StudyError` naming the file and the key.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

import numpy as np

from ..errors import BodyParameterError, HumanoidError, SceneError, StudyError
from .build import DIRECTIONS, body_parameters, scene_for

__all__ = ["OUTPUTS", "Run", "Study", "load_study", "parse_study"]

RUN_KINDS = ("scene", "walk")
KEEP = ("summary", "trajectory")
DISTRIBUTIONS = ("normal", "uniform", "lognormal", "choice")
BODY_KEYS = ("height", "mass", "bmi", "sex", "toes")
PUSH_KEYS = ("force", "fraction", "direction", "frame", "start", "duration")
WALK_KEYS = ("speed", "speed_ratio", "steps", "dt", "mu")
FIGURE_KINDS = ("threshold", "line", "best", "none")

# the summary numbers of a run, by kind: name -> (unit, what)
OUTPUTS = {
    "scene": {
        "survived": ("", "completed without a fall"),
        "fell_at": ("s", "when the pelvis went below 60 % of its start height (NaN: never)"),
        "t_end": ("s", "simulated time reached"),
        "pelvis_min": ("", "lowest pelvis height over its start height"),
        "com_travel": ("m", "horizontal distance from the start's centre of mass to the end's"),
        "peak_com_speed": ("m/s", "largest speed of the centre of mass"),
        "push_force": ("N", "the push's magnitude (0: none)"),
        "mass": ("kg", "the body's mass"),
        "energy_change": ("J", "total energy at the end minus at the start"),
        "final_speed": ("m/s, rad/s", "largest entry of the velocity at the end (0: at rest)"),
        "max_penetration": ("m", "deepest point below the floor (ground scenes)"),
    },
    "walk": {
        "survived": ("", "walked every step without a fall"),
        "fell_at": ("s", "when it fell (NaN: never)"),
        "t_end": ("s", "simulated time reached"),
        "target_speed": ("m/s", "the speed the gait was fitted for"),
        "speed": ("m/s", "mean speed over the analysed cycles"),
        "cadence": ("steps/min", "mean cadence"),
        "step_length": ("m", "mean step length"),
        "cost_of_transport": ("", "positive joint work over body weight times distance"),
        "grf_first_peak": ("BW", "first peak of the vertical ground force"),
        "slip": ("m", "largest slide of a loaded foot point"),
        "push_force": ("N", "the push's magnitude (0: none)"),
        "mass": ("kg", "the body's mass"),
    },
}


# the most runs one study may have: its run list, its results table and every run's id are
# built before the first run starts; 100,000 runs of a second each is a day on 2 cores, and a
# grid of 1.6 million runs was accepted and never finished listing
MAX_RUNS = 100_000


@dataclass(frozen=True)
class Run:
    """One run of a study: its position, a stable id (a hash of the study's fixed part and
    the run's parameters: the same run has the same id in every invocation) and the
    parameters that vary (with ``sample``, the draw's number, when the study samples)."""

    index: int
    id: str
    params: dict


@dataclass(frozen=True)
class Study:
    """A validated study file (see the module docstring)."""

    name: str
    run: str
    scene: dict | None  # run = scene: the base scene's TOML structure, URDF paths absolute
    keep: str
    seed: int
    fixed: dict
    grid: dict
    sample_n: int
    sample: dict
    figure: dict
    source: str = "<study>"
    text: str = field(default="", repr=False)

    @property
    def fingerprint(self) -> str:
        """A hash of everything that decides the runs' results: a folder of results belongs
        to the study whose fingerprint it records."""
        doc = {"run": self.run, "scene": self.scene, "fixed": self.fixed, "keep": self.keep}
        return _digest(doc)

    def runs(self) -> list[Run]:
        """Every run: each sample (seeded) with each grid combination, in a fixed order."""
        keys = list(self.grid)
        combos = list(itertools.product(*(self.grid[k] for k in keys))) or [()]
        samples = self._draws()
        out: list[Run] = []
        base = self.fingerprint
        for i, draw in enumerate(samples):
            for combo in combos:
                params = {**draw, **dict(zip(keys, combo, strict=True))}
                if self.sample:  # two draws may coincide (clipped): still two runs
                    params = {"sample": i, **params}
                rid = _digest({"study": base, "params": params})[:16]
                out.append(Run(len(out), rid, params))
        return out

    def _draws(self) -> list[dict]:
        if not self.sample:
            return [{}]
        rng = np.random.default_rng(self.seed)
        columns = {k: _draw(rng, spec, self.sample_n) for k, spec in self.sample.items()}
        return [{k: col[i] for k, col in columns.items()} for i in range(self.sample_n)]

    def parameters(self, run: Run) -> dict:
        """The run's full parameters: the study's fixed ones and the run's own."""
        return {**self.fixed, **run.params}

    def payload(self) -> dict:
        """What a worker needs to do any run of the study (plain data: no files to read)."""
        return {"name": self.name, "run": self.run, "scene": self.scene, "keep": self.keep,
                "fixed": self.fixed}  # fmt: skip


def _digest(doc) -> str:
    text = json.dumps(doc, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _draw(rng, spec: dict, n: int) -> list:
    ((kind, args),) = ((k, v) for k, v in spec.items() if k != "clip")
    if kind == "choice":
        return [args[i] for i in rng.integers(0, len(args), size=n)]
    if kind == "normal":
        x = rng.normal(args[0], args[1], size=n)
    elif kind == "lognormal":  # args: the median and the geometric standard deviation
        x = args[0] * np.exp(np.log(args[1]) * rng.normal(size=n))
    else:
        x = rng.uniform(args[0], args[1], size=n)
    if "clip" in spec:
        x = np.clip(x, *spec["clip"])
    return [float(v) for v in x]


# -- reading and checking ---------------------------------------------------------------------


def load_study(path: str | Path) -> Study:
    """Read and check a study file. Raises StudyError naming the file and the key."""
    path = Path(path)
    if not path.is_file():
        raise StudyError(f"study file not found: {path}")
    try:
        text = path.read_text(encoding="utf-8")
        doc = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise StudyError(f"{path}: not valid TOML: {exc}") from None
    except OSError as exc:
        raise StudyError(f"cannot read study file {path}: {exc}") from None
    study = parse_study(doc, source=str(path), base=path.parent, text=text)
    check_runs(study)
    return study


def parse_study(doc: dict, source: str = "<study>", base: Path | None = None,
                text: str = "") -> Study:  # fmt: skip
    """A :class:`Study` from the TOML structure (scene files resolve from ``base``)."""

    def bad(key: str, why: str) -> NoReturn:
        raise StudyError(f"{source}: {key}: {why}")

    unknown = set(doc) - {"study", "set", "grid", "sample", "figure"}
    if unknown:
        bad(sorted(unknown)[0], "unknown section (sections: study, set, grid, sample, figure)")
    head = _table(doc.get("study"), "study", bad)
    for key in head:
        if key not in ("name", "run", "scene", "keep", "seed", "description"):
            bad(f"study.{key}", "unknown key (name, run, scene, keep, seed, description)")
    name = head.get("name")
    if not isinstance(name, str) or not name or any(c in name for c in "/\\:") or name[0] == ".":
        bad("study.name", f"give a name usable as a folder name, got {name!r}")
    run = head.get("run", "scene")
    if run not in RUN_KINDS:
        bad("study.run", f"one of {', '.join(RUN_KINDS)}, got {run!r}")
    keep = head.get("keep", "summary")
    if keep not in KEEP:
        bad("study.keep", f"one of {', '.join(KEEP)}, got {keep!r}")
    seed = head.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        bad("study.seed", f"a non-negative integer, got {seed!r}")
    scene = None
    if run == "scene":
        if not isinstance(head.get("scene"), str):
            bad("study.scene", "run = 'scene' needs a scene: a shipped name or a file")
        scene = _base_scene(head["scene"], base, lambda why: bad("study.scene", why))
    elif "scene" in head:
        bad("study.scene", "only with run = 'scene'")
    fixed = _params(_table(doc.get("set", {}), "set", bad), "set", run, bad)
    grid_doc = _table(doc.get("grid", {}), "grid", bad)
    grid = {}
    for key, values in grid_doc.items():
        if not isinstance(values, list) or not values:
            bad(f"grid.{key}", f"a non-empty list of values, got {values!r}")
        grid[key] = values
    for k, values in grid.items():
        for v in values:
            _params({k: v}, "grid", run, bad)
    sample_doc = dict(_table(doc.get("sample", {}), "sample", bad))
    n = sample_doc.pop("n", 0 if not sample_doc else None)
    if sample_doc and (not isinstance(n, int) or isinstance(n, bool) or n < 1):
        bad("sample.n", f"the number of draws, a positive integer, got {n!r}")
    sample = {}
    for key, spec in sample_doc.items():
        _params({key: None}, "sample", run, bad, check_values=False)
        sample[key] = _distribution(spec, f"sample.{key}", bad)
    overlap = (set(fixed) & set(grid)) | (set(fixed) & set(sample)) | (set(grid) & set(sample))
    if overlap:
        bad(sorted(overlap)[0], "given in more than one of set, grid and sample")
    given = set(fixed) | set(grid) | set(sample)
    for a, b in (("body.mass", "body.bmi"), ("push.force", "push.fraction"),
                 ("walk.speed", "walk.speed_ratio")):  # fmt: skip
        if a in given and b in given:
            bad(b, f"give {a} or {b}, not both")
    body = {k for k in given if k.startswith("body.")}
    if body and not ({"body.height", "body.sex"} <= body and body & {"body.mass", "body.bmi"}):
        bad(sorted(body)[0], "a body needs body.height, body.sex and body.mass or body.bmi")
    push = {k for k in given if k.startswith("push.")}
    if push and not push & {"push.force", "push.fraction"}:
        bad(sorted(push)[0], "a push needs push.force [N] or push.fraction [body weights]")
    count = max(n or 1, 1) * math.prod(len(v) for v in grid.values())
    if count > MAX_RUNS:
        sizes = " x ".join([*(str(len(v)) for v in grid.values()), *([str(n)] if n else [])])
        bad("grid" if grid else "sample.n", f"{sizes} = {count:,} runs, more than {MAX_RUNS:,}: "
            "split the study or sample it (sample.n)")  # fmt: skip
    columns = given | set(OUTPUTS[run]) | {"status", "wall_time", "sample"}
    figure = _figure(_table(doc.get("figure", {}), "figure", bad), columns, bad)
    return Study(name, run, scene, keep, seed, fixed, grid, n or 0, sample, figure, source,
                 text)  # fmt: skip


def _table(value, key: str, bad) -> dict:
    if value is None:
        bad(key, "missing section")
    if not isinstance(value, dict):
        bad(key, f"a table, got {type(value).__name__}")
    return value


def _base_scene(name: str, base: Path | None, bad) -> dict:
    """The base scene's TOML structure, its body's URDF path made absolute."""
    from ..scene import Scene

    p = Path(name)
    if base is not None and not p.is_absolute() and (base / p).is_file():
        p = base / p
    try:
        scene = Scene.load(p if p.is_file() else name)
    except SceneError as exc:
        bad(str(exc))
    doc = scene.to_dict()
    if "urdf" in doc["body"]:
        urdf = Path(doc["body"]["urdf"])
        if urdf.is_file():
            doc["body"]["urdf"] = str(urdf.resolve())
    return doc


def _params(table: dict, section: str, run: str, bad, check_values: bool = True) -> dict:
    """Check a section's parameter names (and their values)."""
    out = {}
    for key, value in table.items():
        where = f"{section}.{key}"
        group, _, name = key.partition(".")
        if group == "body" and name in BODY_KEYS:
            pass
        elif group == "push" and name in PUSH_KEYS:
            pass
        elif group == "scene" and name:
            if run != "scene":
                bad(where, "scene.* parameters only with run = 'scene'")
        elif group == "walk" and name in WALK_KEYS:
            if run != "walk":
                bad(where, "walk.* parameters only with run = 'walk'")
        else:
            bad(where, "unknown parameter (body.height|mass|bmi|sex|toes, push.force|fraction|"
                       "direction|frame|start|duration, scene.KEY, walk.speed|speed_ratio|"
                       "steps|dt|mu)")  # fmt: skip
        if check_values:
            _check_value(key, value, where, bad)
        out[key] = value
    return out


def _check_value(key: str, value, where: str, bad) -> None:
    if key == "body.toes":
        if not isinstance(value, bool):
            bad(where, f"true or false, got {value!r}")
    elif key in ("body.sex", "push.frame"):
        if not isinstance(value, str):
            bad(where, f"a string, got {value!r}")
        if key == "body.sex" and value not in ("male", "female"):
            bad(where, f"male or female, got {value!r}")
    elif key == "push.direction":
        if isinstance(value, str):
            if value not in DIRECTIONS:
                bad(where, f"one of {', '.join(DIRECTIONS)} or an angle [deg], got {value!r}")
        elif not _number(value):
            bad(where, f"a direction name or an angle [deg], got {value!r}")
    elif key == "walk.steps":
        if not isinstance(value, int) or isinstance(value, bool) or value < 4:
            bad(where, f"an integer of at least 4 steps, got {value!r}")
    elif key.startswith("scene."):
        pass  # checked by building the scene (check_runs)
    elif not _number(value) or (value <= 0 and key not in ("push.start",)) or value < 0:
        bad(where, f"a positive number, got {value!r}")


def _number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _distribution(spec, where: str, bad) -> dict:
    if not isinstance(spec, dict):
        bad(where, f"a distribution table ({', '.join(DISTRIBUTIONS)} = [...]), got {spec!r}")
    kinds = [k for k in spec if k != "clip"]
    if len(kinds) != 1 or kinds[0] not in DISTRIBUTIONS or set(spec) - {*DISTRIBUTIONS, "clip"}:
        bad(where, f"exactly one of {', '.join(DISTRIBUTIONS)} (and optionally clip)")
    kind, args = kinds[0], spec[kinds[0]]
    if not isinstance(args, list) or not args:
        bad(f"{where}.{kind}", f"a list, got {args!r}")
    if kind != "choice":
        if len(args) != 2 or not all(_number(a) for a in args):
            bad(f"{where}.{kind}", f"two numbers, got {args!r}")
        if kind == "uniform" and not args[0] < args[1]:
            bad(f"{where}.{kind}", f"[low, high] with low < high, got {args!r}")
        if kind in ("normal", "lognormal") and not args[1] > 0:
            bad(f"{where}.{kind}", f"a positive spread, got {args!r}")
    if "clip" in spec:
        c = spec["clip"]
        if not isinstance(c, list) or len(c) != 2 or not all(_number(a) for a in c) or c[0] >= c[1]:
            bad(f"{where}.clip", f"[low, high] with low < high, got {c!r}")
        if kind == "choice":
            bad(f"{where}.clip", "not with choice")
    return dict(spec)


def _figure(doc: dict, columns: set, bad) -> dict:
    kind = doc.get("kind", "none")
    if kind not in FIGURE_KINDS:
        bad("figure.kind", f"one of {', '.join(FIGURE_KINDS)}, got {kind!r}")
    allowed = {"kind", "value", "where", "of", "reference", "also", "x", "series", "panels",
               "title", "label"}  # fmt: skip
    for key in doc:
        if key not in allowed:
            bad(f"figure.{key}", f"unknown key ({', '.join(sorted(allowed))})")
    if kind == "none":
        return dict(doc, kind="none")
    need = {"threshold": ("value", "where", "x"), "line": ("value", "x"),
            "best": ("value", "of", "x")}[kind]  # fmt: skip
    for key in need:
        if not isinstance(doc.get(key), str):
            bad(f"figure.{key}", f"figure kind {kind!r} needs {key} (a column name)")
    also = doc.get("also", [])
    if not isinstance(also, list) or not all(isinstance(c, str) for c in also):
        bad("figure.also", f"a list of column names, got {also!r}")
    for key, col in [*((k, doc.get(k)) for k in ("value", "where", "of", "reference", "x",
                                                  "series", "panels")),
                     *(("also", c) for c in also)]:  # fmt: skip
        if col is not None and not isinstance(col, str):
            bad(f"figure.{key}", f"a column name (a string), got {col!r}")
        if col is not None and col not in columns:
            bad(
                f"figure.{key}",
                f"{col!r} is not a column of the study's table (its "
                f"parameters and outputs: {', '.join(sorted(columns))})",
            )
    return dict(doc)


def check_runs(study: Study) -> None:
    """Every run's body is valid and (run = scene) its scene builds; raises StudyError naming
    the key. (Bodies and scenes are checked without loading models: cheap for 10^4 runs.)"""
    for run in study.runs():
        params = study.parameters(run)
        try:
            body_parameters(params)
        except BodyParameterError as exc:
            key = next((k for k in ("body.height", "body.mass", "body.bmi")
                        if k.split(".")[1] in str(exc)), "body")  # fmt: skip
            section = _section(study, key)
            raise StudyError(f"{study.source}: {section}{key}: run {run.index} "
                             f"({_describe(run.params)}): {exc}") from None  # fmt: skip
        if study.run == "scene":
            try:
                scene_for(study.payload(), params)
            except SceneError as exc:
                keys = [k for k in params if k.startswith("scene.")]
                key = next((k for k in keys if k.split(".", 1)[1].split(".")[-1] in str(exc)),
                           keys[0] if keys else "study.scene")  # fmt: skip
                raise StudyError(f"{study.source}: {_section(study, key)}{key}: {exc}") from None
            except HumanoidError as exc:
                raise StudyError(f"{study.source}: run {run.index}: {exc}") from None


def _section(study: Study, key: str) -> str:
    for name, table in (("set", study.fixed), ("grid", study.grid), ("sample", study.sample)):
        if key in table:
            return f"{name}."
    return ""


def _describe(params: dict) -> str:
    return ", ".join(f"{k} = {v}" for k, v in params.items())
