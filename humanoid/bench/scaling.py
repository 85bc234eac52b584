"""``humanoid bench scaling``: how a step's cost grows with the body's size and its contacts.

Bodies: the shipped male body, example-robot-data's human, Talos, Romeo (its massless fingers
merged) and g1, and the male body with k extra trunk segments (k = 4 ... 32: a chain of ball
joints out of the thorax, each with a slice of a 2 kg, 0.3 m segment: nv grows by 3 per
segment, the structure of a finer spine). For each: one step of Pinocchio's ``aba`` and
``integrate`` (contact-free), ``constraintDynamics`` and ``integrate`` with both soles welded,
and the project's native solve of the same (its constraints' twins, :class:`NativeSolve`,
plus ``integrate``), best of several rounds in the same run. A line fitted to time against
nv gives the cost per degree of freedom; the growth between the two largest bodies,
log(t2 / t1) / log(nv2 / nv1), the order where the fixed costs no longer hide it (1 for
linear, as ABA is; the constrained solve's sparse factorisation grows with the tree's depth
too, which the long trunk chains add).

Contacts: the male body with 0 to 5 welded frames (soles, hands, head; 6 rows each) through
the native solve: time against the number of constraint rows.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from .common import best_time, load_male, write_rows

__all__ = ["SCALING_COLUMNS", "run_scaling_benchmark"]

SCALING_COLUMNS = ["body", "nv", "aba", "constraint_dynamics", "native"]
EXTRA = (4, 8, 16, 32)  # extra trunk segments of the synthetic bodies


def _longer_trunk(h, k: int):
    """The model of ``h`` with k ball joints chained out of its thorax (a finer spine)."""
    model = h.model.copy()
    parent = model.frames[model.getFrameId("thorax")].parentJoint
    mass, length = 2.0 / k, 0.3 / k
    for i in range(k):
        placement = pin.SE3(np.eye(3), np.array([0.0, 0.0, length]))
        j = model.addJoint(parent, pin.JointModelSpherical(), placement, f"extra_{i}")
        inertia = pin.Inertia.FromCylinder(mass, 0.05, length)
        model.appendBodyToJoint(j, inertia, pin.SE3(np.eye(3), np.array([0, 0, length / 2])))
        parent = j
    return model


def _welds(model, frames, q):
    from ..constraints import Weld

    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return [Weld(model.frames[f].name, f, data.oMf[f]) for f in frames]


def _case(model, q, frames, n, rounds) -> dict:
    """Seconds per step of ABA, constraintDynamics and the native solve (+ integrate)."""
    from ..constraints.native import NativeSolve

    rng = np.random.default_rng(0)
    v = 0.1 * rng.normal(size=model.nv)
    tau = np.zeros(model.nv)
    dt = 1e-3
    data = model.createData()

    def aba():
        a = pin.aba(model, data, q, v, tau, pin.Convention.WORLD)
        pin.integrate(model, q, (v + dt * a) * dt)

    welds = _welds(model, frames, q)
    solve = NativeSolve(model, welds)
    cms, cds = solve.cms, solve.cds
    cdata = model.createData()
    pin.initConstraintDynamics(model, cdata, cms, cds)
    prox = pin.ProximalSettings(1e-12, 1e-12, 0.0, 1)

    def theirs():
        a = pin.constraintDynamics(model, cdata, q, v, tau, cms, cds, prox)
        pin.integrate(model, q, (v + dt * a) * dt)

    def ours():
        a = solve.acceleration(q, v, tau)
        pin.integrate(model, q, (v + dt * a) * dt)

    return {"aba": best_time(aba, n, rounds), "constraint_dynamics": best_time(theirs, n, rounds),
            "native": best_time(ours, n, rounds)}  # fmt: skip


def run_scaling_benchmark(quick: bool = False, out: str | Path = "results/bench") -> int:
    """Time the bodies and the contact counts; print, write ``scaling.csv``,
    ``scaling_contacts.csv`` and ``scaling.png``."""

    from ..model import load_example

    n, rounds = (300, 3) if quick else (2000, 7)
    male = load_male()
    bodies = [("male", male, male.model)]
    for name, kw in (("human", {}), ("talos", {}), ("romeo", {"massless": "merge"}),
                     ("g1", {})):  # fmt: skip
        h = load_example(name, **kw)
        bodies.append((name, h, h.model))
    for k in EXTRA:
        bodies.append((f"male + {k} trunk", male, _longer_trunk(male, k)))
    rows = []
    for name, h, model in bodies:
        q = pin.neutral(model)
        q[: h.model.nq] = h.standing_configuration()
        soles = [model.getFrameId(f) for f in h.feet]
        row = {"body": name, "nv": model.nv} | _case(model, q, soles, n, rounds)
        rows.append(row)
        print(f"{name:<16} nv {model.nv:>3}  aba {row['aba'] * 1e6:6.1f} us  "
              f"constraintDynamics {row['constraint_dynamics'] * 1e6:6.1f} us  "
              f"native {row['native'] * 1e6:6.1f} us")  # fmt: skip
    frames = [male.sole_id("left"), male.sole_id("right")] + [
        male.model.getFrameId(f) for f in ("left_hand", "right_hand", "head")
    ]
    q = male.standing_configuration()
    contacts = []
    for k in range(len(frames) + 1):
        t = _case(male.model, q, frames[:k], n, rounds) if k else None
        rows_k = 6 * k
        native = t["native"] if t else _case(male.model, q, frames[:1], n, rounds)["aba"]
        contacts.append({"rows": rows_k, "native": native})
        print(f"{k} welded frames ({rows_k:>2} rows): native {native * 1e6:6.1f} us")
    fits = _fits(rows)
    for key, (per_dof, order) in fits.items():
        print(f"{key}: {per_dof * 1e6:.2f} us per degree of freedom; grows as nv^{order:.2f} "
              "between the two largest bodies")  # fmt: skip
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    write_rows(folder / "scaling.csv", rows, SCALING_COLUMNS)
    write_rows(folder / "scaling_contacts.csv", contacts)
    figure = _plot(rows, contacts, fits, folder / "scaling.png")
    print(f"wrote {folder / 'scaling.csv'}, {folder / 'scaling_contacts.csv'} and {figure}")
    return 0


def _fits(rows) -> dict:
    """Per series: (slope of time against nv [s per dof], the growth exponent between the two
    largest bodies)."""
    nv = np.array([r["nv"] for r in rows], dtype=float)
    i, j = np.argsort(nv)[-2:]
    out = {}
    for key in SCALING_COLUMNS[2:]:
        t = np.array([r[key] for r in rows])
        slope = np.polyfit(nv, t, 1)[0]
        order = np.log(t[j] / t[i]) / np.log(nv[j] / nv[i])
        out[key] = (float(slope), float(order))
    return out


def _plot(rows, contacts, fits, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    nv = np.array([r["nv"] for r in rows])
    labels = {"aba": "pin.aba (no contact)", "constraint_dynamics":
              "pin.constraintDynamics (2 welds)", "native": "native solve (2 welds)"}  # fmt: skip
    for key, label in labels.items():
        t = np.array([r[key] for r in rows]) * 1e6
        slope, order = fits[key]
        a.plot(nv, t, "o", label=f"{label}: {slope * 1e6:.2f} us/dof; nv^{order:.2f} at the end")
        x = np.linspace(nv.min(), nv.max(), 50)
        a.plot(x, np.polyval(np.polyfit(nv, t, 1), x), "-", lw=0.8, color=a.lines[-1].get_color())
    for r in rows:
        if "trunk" not in r["body"]:
            a.annotate(r["body"], (r["nv"], r["native"] * 1e6), fontsize=7, xytext=(3, 3),
                       textcoords="offset points")  # fmt: skip
    a.set_xlabel("nv (degrees of freedom)")
    a.set_ylabel("one step [us] (with integrate)")
    a.set_title("cost against the body's size")
    a.legend(fontsize=7)
    b.plot([c["rows"] for c in contacts], [c["native"] * 1e6 for c in contacts], "o-")
    b.set_xlabel("constraint rows (6 per welded frame)")
    b.set_ylabel("one step [us]")
    b.set_title("cost against the contacts (male body)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
