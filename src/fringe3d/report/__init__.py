"""Self-contained HTML measurement reports (``fringe3d report RESULTS``)."""
from .html import build_report, write_report

__all__ = ["build_report", "write_report"]
