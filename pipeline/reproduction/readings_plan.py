"""The readings study's plan: what it needs before the document's one batch of studies.

The readings tables (cached), the candidate readings, the re-runs of Tables 1-3 and Fig. 8
under the best H4 reading (``requests``) and the candidates' optimality checks not yet cached
(``tasks``); :mod:`.readings_study` writes the section from them after the batch.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd

from pipeline.reproduction.driver import Reproduction
from pipeline.reproduction.h4 import TABLE_EXPERIMENTS


def fmt_pair(v: float, g: float) -> str:
    return f"{v:.4g} / {g:.3f}"


def plan(r: Reproduction) -> SimpleNamespace:
    """What the study needs before its batch: the readings tables (cached, ~0.3 s), the
    candidate readings, the re-run experiments under the best H4 reading (``requests``) and
    the candidates' optimality checks not yet cached (``tasks``), so that
    :func:`pipeline.reproduction.write_document` runs them in its one batch."""
    from pipeline.reproduction import readings as rd

    cache = str(r.output_dir / "cache")
    h4_all = rd.h4_readings()
    h4 = r.memo(rd.h4_table)(h4_all)
    default = rd.Reading("h4", (("base", "scaled"), ("homogenising", "h")), (-45.0, 45.0))
    shown = pd.concat([h4.head(8), h4[h4["reading"] == default.label]]).drop_duplicates("reading")
    names = list(rd.H4_PAPER)
    rows = [
        [
            row["reading"] + (" (default)" if row["reading"] == default.label else ""),
            f"{row['score']:.2f}",
            "yes" if row["paper's GDI order"] else "no",
            *[fmt_pair(row[f"{n} V"], row[f"{n} GDI"]) for n in names],
        ]
        for _, row in shown.iterrows()
    ]
    paper_row = ["paper", "", "", *[fmt_pair(rd.H4_PAPER[n]["V"], rd.H4_PAPER[n]["gdi"]) for n in names]]
    by_label = {reading.label: reading for reading in h4_all}
    candidates = [by_label[label] for label in h4["reading"].head(3)] + [default]
    paper_x = {
        "max V": np.array([rd.H4_PAPER["Table 1 (max V)"][k] / 100 for k in ("d", "h", "Qz")]),
        "max GDI": np.array([rd.H4_PAPER["Table 2 (max GDI)"][k] / 100 for k in ("d", "h", "Qz")]),
        "η(0.5)": np.array([rd.H4_PAPER["Table 3 (w_d = 0.5)"][k] / 100 for k in ("d", "h", "Qz")]),
    }
    # Tricept
    tri_all = rd.tricept_readings()
    tri = r.memo(rd.tricept_table)(tri_all)
    tri_default = rd.Reading(
        "tricept",
        (
            ("cone_joints", "both"),
            ("cone_reference", "normal"),
            ("offset_side", 1),
            ("tilt_limit", None),
            ("homogenising", "arm"),
        ),
        (-90.0, 90.0),
    )
    tri_shown = pd.concat([tri.head(8), tri[tri["reading"] == tri_default.label]]).drop_duplicates("reading")
    tri_rows = [
        [
            row["reading"] + (" (default)" if row["reading"] == tri_default.label else ""),
            f"{row['score']:.2f}",
            f"{row['V']:.1f}",
            f"{row['1/κ min']:.2f}-{row['1/κ max']:.2f}",
        ]
        for _, row in tri_shown.iterrows()
    ]
    tri_by_label = {reading.label: reading for reading in tri_all}
    tri_candidates = [tri_by_label[label] for label in tri["reading"].head(2)]
    if tri_default not in tri_candidates:
        tri_candidates.append(tri_default)
    tri_candidates.append(tri_by_label[tri[tri["reading"].str.contains("tilt_limit=30")]["reading"].iloc[0]])
    tilt_row = tri[tri["reading"] == tri_candidates[-1].label].iloc[0]
    tilt_note = (
        f"1/κ {tilt_row['1/κ min']:.2f}-{tilt_row['1/κ max']:.2f} for the paper's design, the readings "
        f"whose smallest 1/κ comes nearest the paper's 0.57"
    )
    tri_x = {"max V": np.array([rd.TRICEPT_PAPER[k] for k in ("a", "b", "d")])}
    h4_calls = [(c, paper_x, cache) for c in candidates]
    tri_calls = [(c, tri_x, cache, (0.0,)) for c in tri_candidates]
    # the re-runs under the best reading, and the optimality checks (CMA-ES runs)
    preset = rd.reading_preset(candidates[0])
    requests = [(name, (f"+reading={preset}",)) for name in (*TABLE_EXPERIMENTS, "h4_fig8_coarse")] if preset else []
    tasks = r.pending(rd.check_reading, [*tri_calls, *h4_calls])
    return SimpleNamespace(
        h4=h4,
        names=names,
        rows=rows,
        paper_row=paper_row,
        candidates=candidates,
        default=default,
        tri=tri,
        tri_default=tri_default,
        tri_rows=tri_rows,
        tri_candidates=tri_candidates,
        tilt_note=tilt_note,
        h4_calls=h4_calls,
        tri_calls=tri_calls,
        preset=preset,
        requests=requests,
        tasks=tasks,
    )
