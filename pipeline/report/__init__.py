"""Report layer: the HTML page of a sweep or dataset, and the Markdown tables of documents."""

from pipeline.report.html import build_report, load_sweep, write_report

__all__ = ["build_report", "load_sweep", "write_report"]
