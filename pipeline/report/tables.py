"""Markdown tables and relative differences for the documents (reproduction, paper reports)."""

from __future__ import annotations

import math


def rel(ours: float, paper: float) -> str:
    """Relative difference ``(ours - paper) / |paper|`` in percent, as text ("n/a" if undefined)."""
    if paper == 0 or not math.isfinite(ours):
        return "n/a"
    return f"{100 * (ours - paper) / abs(paper):+.1f} %"


def table(header: list[str], rows: list[list]) -> str:
    """A Markdown table; floats with 6 significant digits."""

    def fmt(v):
        if isinstance(v, float):
            return f"{v:.6g}"
        return str(v)

    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"]
    lines += ["| " + " | ".join(fmt(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)
