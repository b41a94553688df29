"""The report's text: numbers for tables and sentences, figures, the link to the notes
on the paper's contradictions."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.report.paper import NOTES_PAGE


def _fig(report: Any, fig: Any, caption: str) -> None:
    import matplotlib.pyplot as plt

    report.figure(fig, caption=caption)
    plt.close(fig)


def _num(x: Any, nd: int = 3) -> Any:
    if x is None:
        return None
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return round(float(x), nd) if isinstance(x, float | np.floating) else x


def _text(x: Any, unit: str = "") -> str:
    """A number for a sentence: 4 significant digits and its unit, or "n/a"."""
    x = _num(x)
    if x is None:
        return "n/a"
    return f"{x:.4g} {unit}".strip() if isinstance(x, float) else f"{x} {unit}".strip()


def _notes_href(out: Path) -> str | None:
    """A link from ``out`` to the page on the paper's contradictions, in a source checkout."""
    import os

    import thermoswarm

    page = Path(thermoswarm.__file__).resolve().parents[2] / NOTES_PAGE
    return os.path.relpath(page, out.resolve()) if page.is_file() else None


def _notes_link(rep: Any, out: Path, before: str, after: str = "") -> None:
    href = _notes_href(out)
    if href is None:
        rep.paragraph(f"{before}{NOTES_PAGE} in the thermoswarm sources{after}")
    else:
        rep.link(NOTES_PAGE, href, before=before, after=after)
