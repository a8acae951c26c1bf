"""Discretisation error vs cost of the workspace integral, old (cell-centre count) vs new
(boundary-fraction grid), for every mechanism; writes docs/accuracy.md and its log-log figure.

Run: ``python -m benchmarks.accuracy`` (about two minutes on 2 cores).

For each mechanism, designs are the test suite's paper design, two random designs of the
design box (seeded) and, where documented, an optimum of docs/reproduction.md. The reference
of each design is the new method at :data:`REFERENCE_FACTOR` x the default resolution,
cross-checked against the old method at the same resolution (printed). Each method is timed
at a ladder of resolutions in the same run (best of :data:`REPEATS`, one core), so the cost
ratios are side by side. The error of a method at a resolution is the largest relative error
over the designs of V, GDI and eta (w_d = 0.5).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from kinematics import MECHANISMS, get_mechanism  # noqa: E402
from kinematics.workspace import default_resolution, evaluate  # noqa: E402

#: the reference resolution, in multiples of the default
REFERENCE_FACTOR = 4
#: resolutions of the ladder, in multiples of the default
LADDER = (0.5, 0.75, 1.0, 1.5, 2.0)
REPEATS = 3
W_D = 0.5
DOCS = Path(__file__).resolve().parent.parent / "docs"
FIGURE = DOCS / "figures" / "accuracy_convergence.png"

#: one design per mechanism from the papers (tests/conftest.py) and documented optima
PAPER = {
    "h4": dict(d=6.0, h=6.0, Qz=42.0),
    "tricept": dict(a=250.0, b=400.0, d=100.0),
    "rpr3": dict(base=[[0, 0], [200, 0], [0, 200]], platform=[[0, 0], [50, 0], [40, 40]],
                 rho_min=80.0, rho_max=160.0),
    "rpr2": dict(b=5.0, q_min=6.0, q_max=9.6),
    "delta": dict(R=200.0, r=50.0, la=200.0, lb=400.0),
}
#: optima documented in docs/reproduction.md (design vectors as printed there)
OPTIMA = {
    "h4": [dict(d=13.52484, h=13.88781, Qz=35.18892)],  # seed 000 Table 1 design
    "tricept": [dict(a=200.1, b=300.0, d=191.3), dict(a=203.6, b=303.4, d=186.2)],
}


def designs(name: str, seed: int = 0) -> list[tuple[str, object]]:
    """(label, mechanism) pairs: paper design, documented optima, two random designs."""
    cls = MECHANISMS[name]
    out = [("paper", get_mechanism(name, **PAPER[name]))]
    out += [(f"optimum {k}", get_mechanism(name, **d)) for k, d in enumerate(OPTIMA.get(name, []))]
    rng = np.random.default_rng(seed)
    found = 0
    while found < 2 and cls.design_variables:
        x = [rng.uniform(v.lower, v.upper) for v in cls.design_variables]
        mech = cls.from_design(np.array(x), **cls.default_fixed)
        if evaluate(mech, resolution=12, error_estimate=False).volume > 0:
            out.append((f"random {found}", mech))
            found += 1
    return out


def best_time(func, repeats: int = REPEATS) -> float:
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - start)
    return best


def quantities(ev) -> np.ndarray:
    return np.array([ev.volume, ev.gdi, ev.mixed(W_D)])


def study(name: str) -> dict:
    cases = designs(name)
    r0 = default_resolution(cases[0][1])
    refs, cross = [], []
    for _, mech in cases:
        ref = evaluate(mech, resolution=REFERENCE_FACTOR * r0, error_estimate=False)
        old_ref = evaluate(mech, resolution=REFERENCE_FACTOR * r0, method="midpoint", error_estimate=False)
        refs.append(quantities(ref))
        cross.append(np.abs(quantities(old_ref) / quantities(ref) - 1))
    rows = []
    for method in ("midpoint", "grid"):
        for factor in LADDER:
            res = max(int(round(factor * r0)), 2)
            errors, seconds = [], []
            for (_, mech), ref in zip(cases, refs):
                evaluate(mech, resolution=res, method=method, error_estimate=False)  # compile, warm
                seconds.append(best_time(lambda: evaluate(mech, resolution=res, method=method,
                                                          error_estimate=False)))
                errors.append(np.abs(quantities(evaluate(mech, resolution=res, method=method,
                                                         error_estimate=False)) / ref - 1))
            err = np.max(errors, axis=0)
            rows.append(dict(method=method, factor=factor, resolution=res, seconds=float(np.mean(seconds)),
                             v=err[0], gdi=err[1], eta=err[2]))
    # error bars: the evaluation's own estimate (shifted grid) against the true error, default resolution
    calibration = []
    for (label, mech), ref in zip(cases, refs):
        ev = evaluate(mech)
        calibration.append((label, abs(ev.volume / ref[0] - 1), ev.volume_error / ref[0],
                            abs(ev.gdi / ref[1] - 1), ev.gdi_error / ref[1]))
    return dict(name=name, r0=r0, cases=[c[0] for c in cases], rows=rows,
                cross=np.max(cross, axis=0), calibration=calibration)


def table(results: list[dict]) -> str:
    lines = ["| mechanism | method | resolution | ms / evaluation | cost vs old default | max error V | GDI | eta |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        base = next(row["seconds"] for row in r["rows"] if row["method"] == "midpoint" and row["factor"] == 1.0)
        for row in r["rows"]:
            mark = " (default)" if row["factor"] == 1.0 else ""
            lines.append(f"| {r['name']} | {'old' if row['method'] == 'midpoint' else 'new'} | "
                         f"{row['resolution']}{mark} | {1e3 * row['seconds']:.1f} | {row['seconds'] / base:.2f} | "
                         f"{100 * row['v']:.3f} % | {100 * row['gdi']:.3f} % | {100 * row['eta']:.3f} % |")
    return "\n".join(lines)


def figure(results: list[dict]) -> None:
    fig, axes = plt.subplots(1, len(results), figsize=(4 * len(results), 3.6), sharey=True)
    for ax, r in zip(axes, results):
        for method, style, label in (("midpoint", "o--", "old: cell-centre count"),
                                     ("grid", "s-", "new: boundary fractions")):
            rows = [row for row in r["rows"] if row["method"] == method]
            cost = [1e3 * row["seconds"] for row in rows]
            err = [100 * max(row["v"], row["gdi"], row["eta"], 1e-6) for row in rows]
            ax.loglog(cost, err, style, label=label)
            for row, c, e in zip(rows, cost, err):
                if row["factor"] == 1.0:
                    ax.annotate("default", (c, e), textcoords="offset points", xytext=(4, 4), fontsize=7)
        ax.axhline(0.1, color="grey", lw=0.8, ls=":")
        ax.set_title(f"{r['name']} (default resolution {r['r0']})")
        ax.set_xlabel("ms per evaluation (one core)")
        ax.grid(True, which="both", lw=0.3)
    axes[0].set_ylabel("max relative error of V, GDI, eta [%]")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURE, dpi=120)


def main() -> None:
    results = []
    for name in sorted(MECHANISMS):
        r = study(name)
        results.append(r)
        print(f"{name}: designs {', '.join(r['cases'])}; reference {REFERENCE_FACTOR}x default, "
              f"old vs new there: V {100 * r['cross'][0]:.3f} %, GDI {100 * r['cross'][1]:.3f} %", flush=True)
    text = table(results)
    print(text)
    calib = ["| mechanism | design | true V error | estimate | true GDI error | estimate |",
             "| --- | --- | --- | --- | --- | --- |"]
    for r in results:
        for label, tv, ev, tg, eg in r["calibration"]:
            calib.append(f"| {r['name']} | {label} | {100 * tv:.3f} % | {100 * ev:.3f} % | "
                         f"{100 * tg:.3f} % | {100 * eg:.3f} % |")
    print("\n".join(calib))
    figure(results)
    cross = "\n".join(f"* {r['name']}: V {100 * r['cross'][0]:.3f} %, GDI {100 * r['cross'][1]:.3f} % "
                      f"(designs: {', '.join(r['cases'])})" for r in results)
    (DOCS / "accuracy_table.md").write_text(
        "<!-- generated by python -m benchmarks.accuracy; do not edit -->\n\n"
        + text + "\n\nOld vs new method at the reference resolution (largest difference over the designs):\n\n"
        + cross + "\n\nError bars at the default resolution (`Evaluation.volume_error`, `gdi_error`) against "
        "the true error (vs the reference):\n\n" + "\n".join(calib) + "\n")


if __name__ == "__main__":
    main()
