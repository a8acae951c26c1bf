"""The readings study: which interpretation of the papers' open choices fits their numbers.

Computations in :mod:`pipeline.reproduction.readings` (cached), planned before the document's
batch by :mod:`pipeline.reproduction.readings_plan`; the re-runs of Tables 1-3 and
Fig. 8 under the best reading are the experiments ``h4_table1/2/3`` and
``h4_fig8_coarse`` with ``+reading=<preset>``.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import matplotlib.pyplot as plt
import pandas as pd

from pipeline.report.tables import rel, table
from pipeline.reproduction.driver import Reproduction
from pipeline.reproduction.h4 import SEEDS, h4_table_runs
from pipeline.reproduction.readings import H4_PAPER
from pipeline.reproduction.readings_plan import fmt_pair
from pipeline.stages.optimise import group_gap_label

#: scores closer than this to the best reading's are a tie (the table prints two decimals)
TIE = 0.005


def readings_study(
    r: Reproduction, planned: SimpleNamespace, default_frames: dict[str, pd.DataFrame], default_sweep: pd.DataFrame
) -> None:
    """Which reading of the papers' open choices fits their numbers (pipeline.reproduction.readings); ``planned``
    is :func:`plan`'s (its re-runs and checks run in the document's batch or, if not, here)."""
    from pipeline.reproduction import readings as rd

    h4, names, rows, paper_row, preset = planned.h4, planned.names, planned.rows, planned.paper_row, planned.preset
    candidates, h4_calls = planned.candidates, planned.h4_calls
    tri, tri_default, tri_rows = planned.tri, planned.tri_default, planned.tri_rows
    tilt_note, tri_calls = planned.tilt_note, planned.tri_calls
    best = candidates[0]
    scaled_preset = rd.reading_preset(rd.Reading("h4", (("base", "scaled"), ("homogenising", "none")), (-15.0, 15.0)))
    # Tables 1-3 and Fig. 8 re-run under the best reading (paper GA, same seeds)
    table_rows, best_sweep = [], None
    if preset:
        extra = (f"+reading={preset}",)
        frames = h4_table_runs(r, extra)
        for label, p in rd.H4_PAPER.items():
            ours, default_frame = frames[label], default_frames[label]
            table_rows.append(
                [
                    label,
                    fmt_pair(p["V"], p["gdi"]),
                    fmt_pair(default_frame["volume"].mean(), default_frame["gdi"].mean()),
                    fmt_pair(ours["volume"].mean(), ours["gdi"].mean()),
                    rel(ours["volume"].mean(), p["V"]),
                    rel(ours["gdi"].mean(), p["gdi"]),
                    group_gap_label(ours),
                ]
            )
        best_sweep = r.experiment("h4_fig8_coarse", extra)
        fig, axes = plt.subplots(1, 2, figsize=(13, 4.4), layout="constrained")
        for ax, (title, sweep) in zip(axes, (("default reading", default_sweep), (f"reading {preset}", best_sweep))):
            ax.plot(sweep["w_d"], sweep["gdi"], "o-", label="GDI")
            ax.plot(sweep["w_d"], sweep["suri"], "s-", label="SURI")
            ax.set_xlabel("$w_d$ [1]")
            ax.set_ylabel("GDI, SURI [1]")
            ax.set_title(f"H4 optima vs $w_d$, {title}")
            ax.grid(alpha=0.3)
            twin = ax.twinx()
            twin.plot(sweep["w_d"], sweep["volume"], "k--", alpha=0.5, label="V")
            twin.set_ylabel("V [cm³·rad]")
            ax.legend(loc="center left")
        fig.savefig(r.figures / "h4_fig8_readings.png", dpi=150)
        plt.close(fig)
    checks = r.memo_map(rd.check_reading, h4_calls)
    check_rows = [
        [
            c["reading"],
            f"{c['max V paper/optimum']:.3f}",
            f"{c['max GDI paper/optimum']:.3f}",
            f"{c['η(0.5) paper/optimum']:.3f}",
            f"{c['spearman V-GDI']:+.2f}",
            f"{c['GDI at max-V / max GDI']:.2f}",
            "none" if c["collapse w_d"] is None else f"{c['collapse w_d']:.2f}",
            " → ".join(f"{v:.3g}" for v in c["sweep V"]),
        ]
        for c in checks
    ]
    tri_checks = r.memo_map(rd.check_reading, tri_calls)
    tri_check_rows = [
        [
            c["reading"],
            f"{c['max V optimum']:.1f}",
            ", ".join(f"{v:.4g}" for v in c["max V design"]),
            f"{c['max V paper/optimum']:.3f}",
            f"{c['spearman V-GDI']:+.2f}",
        ]
        for c in tri_checks
    ]
    best_tri = tri.iloc[0]
    # a near-tie at the top is no finding: the scores of readings this close move with the
    # objective's discretisation (the Tricept's default and its 45 deg tilt limit swapped places,
    # 0.35 both, when its cell rule changed)
    tied = tri.loc[(tri["score"] - best_tri["score"] < TIE) & (tri.index > 0), "reading"].tolist()
    tie_note = (
        f" It leads by less than {TIE} of score (tied to the table's two decimals) over "
        f"{len(tied)} other reading{'s' if len(tied) > 1 else ''}"
        + (", the default among them" if tri_default.label in tied else "")
        + ": the order among them is not a finding."
        if tied
        else ""
    )
    h4_verdict = _h4_verdict(h4, names)
    inert_note = (
        "Under it d has no effect on V or GDI (the base tracks the plate), so it cannot be the default "
        "(every design variable must act; `tests/test_models.py`)."
        if "base=tracking" in best.label
        else "Under it d, h and Qz all act."
    )
    tri_verdict = _tricept_verdict(tri)
    r.add(f"""
## Readings study: which interpretation did the papers use?

Each choice a paper leaves open is a named option of the mechanism (`mechanism.fixed.*` on the
command line; the docstrings of `kinematics/h4.py` and `kinematics/tricept.py` give the equation
each one interprets). Generated by `pipeline/reproduction/readings.py`.

### H4: {len(h4)} readings × the paper's five designs

Each cell is V [cm³·rad, or cm³ at constant θ] / GDI of the paper's design under that reading.
Score: mean |ln(ours/paper)| over V and GDI of the five designs (Table 2's V = 4.1887 = 4π/3 is
left out: it is most likely a floor of the paper's volume routine, an empty workspace, not a
volume). "Order": the paper's GDIs increase T1 < T3(0.25) < T3(0.5) < T3(0.75); does ours? The
best eight and the default:

{table(["reading", "score", "order", *names], [paper_row, *rows])}

{h4_verdict}

For the best three readings and the default: is the paper's optimum (near-)optimal (its objective
over our optimum of the same objective, IPOP-CMA-ES + polish), do V and GDI conflict (Spearman
rank correlation of V and GDI over 64 Sobol designs: negative = conflict; GDI of the max-V
optimum over the best GDI), and where does a w_d sweep collapse the workspace (first w_d whose
optimum has V below 10 % of the w_d = 0 optimum; V along w_d = 0, 0.25, ..., 1)?

{table(["reading", "max V: paper/opt", "max GDI: paper/opt", "η(0.5): paper/opt", "Spearman V-GDI", "GDI at max V / max GDI", "collapse at w_d", "V along the sweep"], check_rows)}

Best reading by score: **{best.label}**, selectable as `+reading={preset}`
(`conf/reading/{preset}.yaml`). {inert_note} The closest reading in which d, h and Qz all act
is the default base with the same length and θ range, `+reading={scaled_preset}`. Run any study
under a reading, e.g. `python -m pipeline +experiment=h4_mixed +reading={preset}`.

### Tables 1-3 and Fig. 8 under the best reading (paper GA 30 × 150, seeds {list(SEEDS)})

V / GDI, mean over the seeds; differences are to the paper.

{table(["study", "paper", "default reading", f"reading {preset}", "V diff.", "GDI diff.", "GA gap to reference"], table_rows)}

![Fig. 8 under two readings](figures/h4_fig8_readings.png)

### Tricept: {len(tri)} readings × the paper's Table 2 design (a, b, d) = (200, 300.062, 20)

Score: mean |ln(ours/paper)| over V = 944.2 mm·rad² and the LCI range 0.57-0.61 (our 1/κ min and
max over the workspace). The best eight and the default:

{table(["reading", "score", "V", "1/κ range"], [["paper", "", "944.2", "0.57-0.61"], *tri_rows])}

Best reading by score: **{best_tri["reading"]}**{" (the default)" if best_tri["reading"] == tri_default.label else ""}.{tie_note}
For the best readings, the default and a central-joint tilt limit of 30° ({tilt_note}): our
maximum-volume optimum (IPOP-CMA-ES + polish, design (a, b, d) in mm) and the paper design's volume
over it:

{table(["reading", "our max V", "design (a, b, d)", "paper V / our max", "Spearman V-GDI"], tri_check_rows)}

The paper's design has d on its 20 mm lower bound; whether it is optimal under a reading is the
"paper V / our max" column (1 = optimal). {tri_verdict}
""")


def _h4_verdict(h4: pd.DataFrame, names: list[str]) -> str:
    """What the H4 readings table shows, stated from its numbers."""
    from pipeline.reproduction.readings import H4_DEGENERATE_V

    def factors(row: pd.Series) -> list[float]:
        out = [
            max(row[f"{n} GDI"] / H4_PAPER[n]["gdi"], H4_PAPER[n]["gdi"] / max(row[f"{n} GDI"], 1e-12)) for n in names
        ]
        out += [
            max(row[f"{n} V"] / H4_PAPER[n]["V"], H4_PAPER[n]["V"] / max(row[f"{n} V"], 1e-12))
            for n in names
            if n not in H4_DEGENERATE_V
        ]
        return out

    worst = h4.apply(lambda row: max(factors(row)), axis=1)
    within2 = int((worst <= 2.0).sum())
    in_range = h4[
        h4.apply(lambda row: all(0.03 <= row[f"{n} GDI"] <= 0.1 for n in names if n not in H4_DEGENERATE_V), axis=1)
    ]
    lengths = sorted({r.split("homogenising=")[1].split(",")[0] for r in in_range["reading"]})
    ordered = int(h4["paper's GDI order"].sum())
    best = h4.iloc[0]
    verdict = (
        f"{within2} of the {len(h4)} readings bring every (V, GDI) pair within a factor 2 of the paper "
        f"(the best reading's worst pair is off by a factor {worst.iloc[0]:.1f}; its score "
        f"{best['score']:.2f} is a typical factor of {math.exp(best['score']):.1f}). "
    )
    if within2 == 0:
        verdict += "**Nothing of Tables 1-3 is reproduced** within any tolerance we would state. "
    verdict += (
        f"What does match: GDIs of the paper's magnitude (0.03-0.1 for the four non-degenerate designs) "
        f"appear under {len(in_range)} readings, all with the homogenising length "
        f"{' or '.join(f'`{x}`' for x in lengths) or '(none)'}; {ordered} readings give the paper's GDI "
        f"order T1 < T3(0.25) < T3(0.5) < T3(0.75)."
    )
    return verdict


def _tricept_verdict(tri: pd.DataFrame) -> str:
    """What the Tricept readings table shows, stated from its numbers (tolerances: 3 % in V, ±0.05 in 1/κ)."""
    from pipeline.reproduction.readings import TRICEPT_PAPER as p

    v_ok = set(tri.loc[(tri["V"] / p["V"] - 1).abs() <= 0.03, "reading"])
    lci_ok = set(
        tri.loc[
            ((tri["1/κ min"] - p["lci_min"]).abs() <= 0.05) & ((tri["1/κ max"] - p["lci_max"]).abs() <= 0.05), "reading"
        ]
    )
    both = v_ok & lci_ok
    text = (
        f"V within 3 % of the paper's {p['V']} mm·rad²: {len(v_ok)} readings; the 1/κ range within ±0.05 of "
        f"{p['lci_min']}-{p['lci_max']}: {len(lci_ok)} readings; both: {len(both)}. "
    )
    if both:
        text += "Table 2 is **reproduced** (V within 3 %, 1/κ within ±0.05) under: " + "; ".join(sorted(both)) + "."
    else:
        text += (
            "No single reading gives both, so Table 2 is **not reproduced**"
            + ("; the volume alone is, within 3 %, under: " + "; ".join(sorted(v_ok)) if v_ok else "")
            + "."
        )
    return text
