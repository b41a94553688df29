"""Reports: a self-contained HTML page builder (:mod:`thermoswarm.report.html`)."""

from thermoswarm.report.html import HtmlReport, format_value

__all__ = ["HtmlReport", "format_value"]
