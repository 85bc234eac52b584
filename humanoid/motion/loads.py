"""External loads: force-plate forces, their centres of pressure and free moments.

A load acts on one body: a foot (``"left"``, ``"right"``: the body its sole frame hangs from)
or any frame of the model by name. It is kept as OpenSim keeps it: the force [N], the point it
acts at (for a force plate, the centre of pressure) [m] and a free moment [N m] (about the
vertical, for a plate), all in world axes. What inverse dynamics applies is the equivalent
wrench about the world origin, ``(f, p x f + tau)``: it is linear in the samples, so loads are
resampled and filtered as wrenches (a centre of pressure is undefined where the force
vanishes).

OpenSim's layout (``read_loads``): per load, columns ``<P>force_vx, <P>force_vy,
<P>force_vz`` (force), ``<P>force_px, ...`` (point) and ``<P>torque_x, ...`` (moment), with a
prefix ``<P>`` such as ``ground_``, ``1_ground_``, ``r_ground_`` or ``l_ground_``; the world is
Y up (X forward, Z right), turned here to ours (x forward, y left, z up). Which foot a load is
on comes from the caller (``sides``), else from the companion ExternalLoads ``.xml``
(``applied_to_body`` ending in ``_r`` or ``_l``), else from a prefix naming the side (``r_``,
``l_``, ``right``, ``left``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..dynamics import centre_of_pressure
from .storage import MotionFileError, Table, read_storage, write_storage

__all__ = ["Load", "OPENSIM_TO_OURS", "read_loads", "read_loads_xml", "write_loads"]

# OpenSim's ground (X forward, Y up, Z right) to ours (x forward, y left, z up): ours = R @ theirs
OPENSIM_TO_OURS = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])

_SIDE_WORDS = {"r": "right", "right": "right", "l": "left", "left": "left"}


@dataclass
class Load:
    """One external load over time (see the module docstring), world axes (ours).

    Attributes:
        body: ``"left"``, ``"right"`` (a foot) or a frame name.
        time: (n,) [s]. force: (n, 3) [N]. point: (n, 3) [m]. torque: (n, 3) [N m].
        name: Its prefix in the file it came from.
    """

    body: str
    time: np.ndarray
    force: np.ndarray
    point: np.ndarray
    torque: np.ndarray
    name: str = ""

    def __post_init__(self) -> None:
        self.time = np.asarray(self.time, dtype=float).reshape(-1)
        n = len(self.time)
        for key in ("force", "point", "torque"):
            a = np.asarray(getattr(self, key), dtype=float)
            if a.shape != (n, 3):
                raise MotionFileError(f"load {self.name or self.body}: {key} must be ({n}, 3)")
            setattr(self, key, a)

    @property
    def wrench(self) -> np.ndarray:
        """The wrench about the world origin, (n, 6): force, then p x f + tau."""
        return np.hstack([self.force, np.cross(self.point, self.force) + self.torque])

    @classmethod
    def from_wrench(cls, body: str, time, wrench, height: float = 0.0, name: str = "") -> Load:
        """The load of a wrench about the world origin (n, 6) as a force at its centre of
        pressure on the plane z = ``height`` plus a free moment about z (zero point and
        moment where the vertical force is under 1e-9 N: the wrench is then a pure moment
        kept in ``torque``)."""
        wrench = np.asarray(wrench, dtype=float).reshape(-1, 6)
        f, m = wrench[:, :3], wrench[:, 3:]
        c = centre_of_pressure(wrench, height)
        ok = np.isfinite(c[:, 0])
        point = np.column_stack([np.where(ok[:, None], c, 0.0), np.where(ok, height, 0.0)])
        torque = np.where(ok[:, None], m - np.cross(point, f), m)
        return cls(body, time, f, point, torque, name)

    def resampled(self, time: np.ndarray) -> np.ndarray:
        """The wrench about the origin at ``time`` (linear; zero outside the load's times:
        nothing measured, no load)."""
        w = self.wrench
        return np.column_stack(
            [np.interp(time, self.time, w[:, i], left=0.0, right=0.0) for i in range(6)]
        )


def read_loads_xml(path: str | Path) -> dict[str, str]:
    """The sides of an OpenSim ExternalLoads file's forces: {column prefix: side}, from each
    ExternalForce's ``force_identifier`` and ``applied_to_body`` (a body ending in ``_r`` is
    the right foot, ``_l`` the left)."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except FileNotFoundError:
        raise MotionFileError(f"external loads file not found: {path}") from None
    except ET.ParseError as exc:
        raise MotionFileError(f"{path}: not XML: {exc}") from None
    out = {}
    for force in root.iter("ExternalForce"):
        body = (force.findtext("applied_to_body") or "").strip()
        ident = (force.findtext("force_identifier") or "").strip()
        side = {"r": "right", "l": "left"}.get(body.rsplit("_", 1)[-1].lower())
        if not ident.endswith("force_v") or side is None:
            raise MotionFileError(
                f"{path}: ExternalForce {force.get('name')!r}: expected a force_identifier "
                f"ending in 'force_v' on a body ending in _r or _l, got {ident!r} on {body!r}"
            )
        out[ident[: -len("force_v")]] = side
    if not out:
        raise MotionFileError(f"{path}: no ExternalForce elements")
    return out


def read_loads(path: str | Path, sides: dict[str, str] | None = None, xml: str | Path | None = None,
               y_up: bool = True) -> list[Load]:  # fmt: skip
    """Read the loads of an OpenSim external loads ``.mot`` (see the module docstring).

    Args:
        path: The ``.mot``/``.sto`` file. sides: {prefix: "left" | "right" | frame name};
            default from ``xml``, or the ``.xml`` of the same name next to the file, or the
            prefixes. y_up: The file's world is OpenSim's (Y up); False: already ours (z up).

    Raises:
        MotionFileError: no load columns, a load without its point or torque columns, a load
            whose side cannot be told (the message lists the prefixes and how to name them).
    """
    table = read_storage(path)
    prefixes = [lab[: -len("force_vx")] for lab in table.labels if lab.endswith("force_vx")]
    if not prefixes:
        raise MotionFileError(
            f"{path}: no load columns (<prefix>force_vx, ..._vy, ..._vz): not an external "
            "loads file"
        )
    if sides is None:
        companion = Path(xml) if xml is not None else Path(path).with_suffix(".xml")
        if xml is not None or companion.exists():
            sides = read_loads_xml(companion)
    sides = dict(sides or {})
    R = OPENSIM_TO_OURS if y_up else np.eye(3)
    loads = []
    for prefix in prefixes:
        side = sides.get(prefix) or _side_from_prefix(prefix)
        if side is None:
            raise MotionFileError(
                f"{path}: which foot bears the load {prefix or '(no prefix)'!r}? Its prefixes: "
                f"{', '.join(repr(p) for p in prefixes)}; name them (sides={{prefix: side}}, "
                "--loads-side PREFIX=SIDE) or give the ExternalLoads .xml"
            )

        def cols(names, prefix=prefix):
            for n in names:
                gaps = np.flatnonzero(np.isnan(table.column(prefix + n)))
                if gaps.size:
                    raise MotionFileError(
                        f"{path}: column {prefix + n!r} is NaN at {gaps.size} samples (first "
                        f"at {table.time[gaps[0]]:g} s): a load needs a value at every sample "
                        "(0 where the foot is off the ground)"
                    )
            return np.column_stack([table.column(prefix + n) for n in names]) @ R.T

        force = cols(("force_vx", "force_vy", "force_vz"))
        point = cols(("force_px", "force_py", "force_pz"))
        torque = cols(("torque_x", "torque_y", "torque_z"))
        loads.append(Load(side, table.time, force, point, torque, prefix))
    return loads


def _side_from_prefix(prefix: str) -> str | None:
    first = prefix.strip("_").split("_", 1)[0].lower()
    return _SIDE_WORDS.get(first)


def write_loads(path: str | Path, loads: list[Load], name: str = "external loads",
                y_up: bool = True, bodies: dict | None = None) -> Path:  # fmt: skip
    """Write loads sharing one time base as an OpenSim external loads ``.mot`` (Y up, unless
    ``y_up`` is False: our axes; prefix ``r_ground_`` / ``l_ground_`` for the feet,
    ``<body>_`` otherwise) and its ExternalLoads ``.xml`` next to it (the feet applied to
    ``calcn_r``/``calcn_l``, the feet of OpenSim's gait models, unless ``bodies`` maps a load's
    body to another)."""
    if not loads:
        raise MotionFileError("no loads to write")
    time = loads[0].time
    if any(len(x.time) != len(time) or not np.array_equal(x.time, time) for x in loads):
        raise MotionFileError("the loads to write must share one time base")
    R = OPENSIM_TO_OURS.T if y_up else np.eye(3)  # ours to the file's
    feet = {"right": "calcn_r", "left": "calcn_l"} | (bodies or {})
    labels, columns, forces = [], [], []
    for x in loads:
        prefix = {"right": "r_ground_", "left": "l_ground_"}.get(x.body, f"{x.body}_")
        for what, a in (("force_v", x.force), ("force_p", x.point), ("torque_", x.torque)):
            labels += [f"{prefix}{what}{c}" for c in "xyz"]
            columns.append(a @ R.T)
        forces.append((prefix, feet.get(x.body, x.body)))
    path = write_storage(path, Table(time, labels, np.hstack(columns), None, name))
    xml = ['<?xml version="1.0" encoding="UTF-8" ?>', '<OpenSimDocument Version="40000">',
           '\t<ExternalLoads name="externalloads">', "\t\t<objects>"]  # fmt: skip
    for prefix, body in forces:
        xml += [
            f'\t\t\t<ExternalForce name="{prefix.rstrip("_")}">',
            f"\t\t\t\t<applied_to_body>{body}</applied_to_body>",
            "\t\t\t\t<force_expressed_in_body>ground</force_expressed_in_body>",
            "\t\t\t\t<point_expressed_in_body>ground</point_expressed_in_body>",
            f"\t\t\t\t<force_identifier>{prefix}force_v</force_identifier>",
            f"\t\t\t\t<point_identifier>{prefix}force_p</point_identifier>",
            f"\t\t\t\t<torque_identifier>{prefix}torque_</torque_identifier>",
            f"\t\t\t\t<data_source_name>{path.name}</data_source_name>",
            "\t\t\t</ExternalForce>",
        ]
    xml += ["\t\t</objects>", f"\t\t<datafile>{path.name}</datafile>", "\t</ExternalLoads>",
            "</OpenSimDocument>"]  # fmt: skip
    path.with_suffix(".xml").write_text("\n".join(xml) + "\n", encoding="utf-8")
    return path
