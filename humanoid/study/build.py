"""A run's body, push and scene from its parameters (shared by the study's checks and its
runs)."""

from __future__ import annotations

import copy
import math

import numpy as np

from ..errors import SceneError

__all__ = ["DIRECTIONS", "G", "PUSH_DEFAULTS", "body_parameters", "push_vector", "scene_for"]

# push directions by name: degrees from forward (+x) towards the left (+y)
DIRECTIONS = {"forward": 0.0, "left": 90.0, "backward": 180.0, "right": 270.0}
PUSH_DEFAULTS = {"push.start": 0.5, "push.duration": 0.2}
G = 9.81  # [m/s^2] a body weight, for push.fraction


def body_parameters(params: dict):
    """The run's :class:`~humanoid.anthropometry.BodyParameters`, or None (the base's body)."""
    from ..anthropometry import BodyParameters

    if "body.height" not in params:
        return None
    height = float(params["body.height"])
    mass = params.get("body.mass")
    mass = float(mass) if mass is not None else float(params["body.bmi"]) * height * height
    return BodyParameters(height, mass, params["body.sex"], toes=params.get("body.toes", True))


def push_vector(params: dict, weight: float) -> np.ndarray:
    """The push's force [N], world axes, from push.force or push.fraction (of ``weight``)
    and push.direction (default forward)."""
    magnitude = (float(params["push.force"]) if "push.force" in params
                 else float(params["push.fraction"]) * weight)  # fmt: skip
    d = params.get("push.direction", "forward")
    angle = math.radians(DIRECTIONS[d] if isinstance(d, str) else float(d))
    return magnitude * np.array([math.cos(angle), math.sin(angle), 0.0])


def scene_for(payload: dict, params: dict, weight: float | None = None):
    """The run's :class:`~humanoid.scene.Scene`: the base scene with the run's ``scene.*``
    keys, body and push. ``weight`` [N] turns push.fraction into newtons (the body's own
    weight when None and the body is the run's; 1 N when only checking)."""
    from ..scene import Scene

    doc = copy.deepcopy(payload["scene"])
    for key, value in params.items():
        if key.startswith("scene."):
            *path, last = key[len("scene.") :].split(".")
            node = doc
            for part in path:
                node = node.setdefault(part, {})
                if not isinstance(node, dict):
                    raise SceneError(f"{key}: {part} is not a table")
            node[last] = value
    body = body_parameters(params)
    if body is not None:
        joints = doc.get("body", {}).get("ball_joints", "quaternion")
        doc["body"] = {"height": body.height, "mass": body.mass, "sex": body.sex,
                       "toes": body.toes, "ball_joints": joints}  # fmt: skip
    if any(k.startswith("push.") for k in params):
        p = {**PUSH_DEFAULTS, **params}
        if weight is None:
            weight = body.mass * G if body is not None else 1.0
        push = {"frame": p.get("push.frame", "thorax"),
                "force": [float(x) for x in push_vector(p, weight)],
                "start": float(p["push.start"]), "duration": float(p["push.duration"])}  # fmt: skip
        effects = doc.setdefault("effects", {})
        effects["pushes"] = [*effects.get("pushes", []), push]
    return Scene.from_dict(doc, source=f"study {payload['name']}")
