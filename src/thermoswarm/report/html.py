"""A small builder of self-contained HTML reports.

One file, no external resource and no time stamp (the same inputs give the same
bytes): styles are inline, Matplotlib figures are embedded
as base64 PNG, animations as base64 GIF (``<img>``) or MP4/WebM (``<video>``).  The
page opens offline and can be mailed or archived as it is.

Example
-------
>>> rep = HtmlReport("Energy analysis")
>>> with rep.section("Summary"):
...     rep.paragraph("Two phases.")
...     rep.table({"kT1": 12.5, "kT2": 48.0})
>>> html = rep.render()

Hand-written (about 300 lines) rather than a templating engine: the pages are simple
and the core install stays free of Jinja and friends.
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from thermoswarm.fsutil import atomic_write_text

__all__ = ["HtmlReport", "format_value"]

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:2em auto;
max-width:1100px;padding:0 1em;color:#222;line-height:1.45}
h1{border-bottom:2px solid #444;padding-bottom:.2em}
h2{border-bottom:1px solid #bbb;margin-top:2em}
table{border-collapse:collapse;margin:.8em 0;font-size:.9em}
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right;vertical-align:top}
th{background:#f0f0f0} td:first-child,th:first-child{text-align:left}
caption{caption-side:top;text-align:left;font-style:italic;padding:.3em 0}
figure{margin:1em 0} figcaption{font-size:.9em;color:#444}
img,video{max-width:100%}
pre{background:#f6f6f6;padding:.6em;overflow-x:auto;font-size:.85em}
.note{color:#555;font-size:.9em} nav ul{columns:2}
table.paper td,table.paper th{text-align:left;max-width:26em}
table.paper td.v{font-weight:600;white-space:nowrap}
.reproduced{color:#11702a} .partly{color:#8a6100} .differs{color:#a11} .notmeasured{color:#666}
.notresolvedatthisscale{color:#666}
.empty{border:1px dashed #bbb;padding:.8em;color:#444;background:#fafafa}
"""


def format_value(value: Any, floatfmt: str = ".4g") -> str:
    """Text of a table cell: numbers formatted, ``None``/NaN as an en dash."""
    if value is None:
        return "\u2013"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "\u2013"
        return format(value, floatfmt)
    try:
        import numpy as np

        if isinstance(value, np.integer):
            return str(int(value))
        if isinstance(value, np.floating):
            return format_value(float(value), floatfmt)
        if isinstance(value, np.ndarray):
            value = value.tolist()
    except ImportError:  # pragma: no cover
        pass
    if isinstance(value, Mapping):  # "a: 1, b: 2", never raw JSON
        return ", ".join(f"{k}: {format_value(v, floatfmt)}" for k, v in value.items())
    if isinstance(value, list | tuple):
        return ", ".join(format_value(v, floatfmt) for v in value)
    return str(value)


class HtmlReport:
    """Accumulates blocks and renders one self-contained HTML page.

    Every method returns ``self`` (chainable) except :meth:`section` (a context
    manager), :meth:`render` and :meth:`write`.
    """

    def __init__(self, title: str, *, subtitle: str | None = None, toc: bool = True) -> None:
        self.title = title
        self.subtitle = subtitle
        self.toc = toc
        self._body: list[str] = []
        self._sections: list[tuple[str, str]] = []
        self._tops: list[int] = []
        self._n_fig = 0

    # -- text ------------------------------------------------------------------------
    def heading(self, text: str, level: int = 2) -> HtmlReport:
        level = min(max(int(level), 1), 6)
        self._body.append(f"<h{level}>{html.escape(text)}</h{level}>")
        return self

    def paragraph(self, text: str, *, note: bool = False) -> HtmlReport:
        cls = ' class="note"' if note else ""
        self._body.append(f"<p{cls}>{html.escape(text)}</p>")
        return self

    def bullets(self, items: Sequence[str]) -> HtmlReport:
        lis = "".join(f"<li>{html.escape(str(i))}</li>" for i in items)
        self._body.append(f"<ul>{lis}</ul>")
        return self

    def code(self, text: str) -> HtmlReport:
        self._body.append(f"<pre>{html.escape(text)}</pre>")
        return self

    def raw(self, fragment: str) -> HtmlReport:
        """Insert an HTML fragment as it is (the caller escapes)."""
        self._body.append(fragment)
        return self

    @contextlib.contextmanager
    def section(self, title: str) -> Iterator[HtmlReport]:
        """``with rep.section("Energy"):`` wraps the blocks added inside."""
        anchor = f"s{len(self._sections) + 1}"
        self._sections.append((anchor, title))
        self._body.append(f'<section id="{anchor}"><h2>{html.escape(title)}</h2>')
        self._tops.append(len(self._body))
        self._body.append("")  # filled by section_top()
        try:
            yield self
        finally:
            self._body.append("</section>")

    @property
    def n_sections(self) -> int:
        """Sections opened so far (the index the next one will have)."""
        return len(self._sections)

    def section_top(self, index: int, fragment: str) -> HtmlReport:
        """Put an HTML fragment right under the heading of section ``index`` (0-based),
        e.g. a summary written once the section's numbers are known."""
        slot = self._tops[index]
        self._body[slot] += fragment
        return self

    def link(self, text: str, href: str, *, before: str = "", after: str = "") -> HtmlReport:
        """A paragraph with one link."""
        self._body.append(
            f'<p>{html.escape(before)}<a href="{html.escape(href, quote=True)}">'
            f"{html.escape(text)}</a>{html.escape(after)}</p>"
        )
        return self

    def empty(self, text: str) -> HtmlReport:
        """A sentence in the place of a plot that would have no data."""
        self._body.append(f'<p class="empty">{html.escape(text)}</p>')
        return self

    @staticmethod
    def comparison_html(rows: Sequence[Mapping[str, str]], *, caption: str | None = None,
                        first: str = "what") -> str:  # fmt: skip
        """The paper beside our result: rows of ``claim``, ``paper``, ``ours``,
        ``verdict`` and ``why`` (:mod:`thermoswarm.report.paper`) as an HTML table."""
        cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
        head = "".join(f"<th>{h}</th>" for h in (first, "the paper", "ours", "verdict", "why"))
        body = []
        for r in rows:
            v = str(r.get("verdict", ""))
            cls = v.replace(" ", "")
            body.append(
                "<tr>" + "".join(f"<td>{html.escape(str(r.get(k, '')))}</td>"
                                 for k in ("claim", "paper", "ours"))
                + f'<td class="v {cls}">{html.escape(v)}</td>'
                + f"<td>{html.escape(str(r.get('why', '')))}</td></tr>"
            )  # fmt: skip
        return (f'<table class="paper">{cap}<thead><tr>{head}</tr></thead>'
                f"<tbody>{''.join(body)}</tbody></table>")  # fmt: skip

    @staticmethod
    def verdicts_html(rows: Sequence[Mapping[str, str]]) -> str:
        """A compact table of ``experiment``, ``claim`` and ``verdict`` rows."""
        body = "".join(
            f"<tr><td>{html.escape(r.get('experiment', ''))}</td>"
            f"<td>{html.escape(r.get('claim', ''))}</td>"
            f'<td class="v {r.get("verdict", "").replace(" ", "")}">'
            f"{html.escape(r.get('verdict', ''))}</td></tr>"
            for r in rows
        )
        head = "<th>experiment</th><th>what the paper shows</th><th>verdict</th>"
        return f'<table class="paper"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'

    def comparison(self, rows: Sequence[Mapping[str, str]], *, caption: str | None = None
                   ) -> HtmlReport:  # fmt: skip
        """:meth:`comparison_html` appended to the page."""
        self._body.append(self.comparison_html(rows, caption=caption))
        return self

    # -- tables ----------------------------------------------------------------------
    def table(
        self,
        rows: Mapping[str, Any] | Sequence[Mapping[str, Any]],
        *,
        columns: Sequence[str] | None = None,
        caption: str | None = None,
        floatfmt: str = ".4g",
        header: tuple[str, str] = ("key", "value"),
    ) -> HtmlReport:
        """A table from a mapping (two columns) or a list of mappings (one row each).

        ``columns`` picks and orders the columns (default: all keys, first seen first).
        """
        if isinstance(rows, Mapping):
            rows = [{header[0]: k, header[1]: v} for k, v in rows.items()]
            columns = list(header)
        rows = list(rows)
        if columns is None:
            columns = []
            for r in rows:
                columns.extend(k for k in r if k not in columns)
        cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
        head = "".join(f"<th>{html.escape(str(c))}</th>" for c in columns)
        body = "".join(
            "<tr>"
            + "".join(f"<td>{html.escape(format_value(r.get(c), floatfmt))}</td>" for c in columns)
            + "</tr>"
            for r in rows
        )
        self._body.append(
            f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
        )
        return self

    # -- media -----------------------------------------------------------------------
    def image(
        self, data: bytes, mime: str = "image/png", *, caption: str | None = None, alt: str = ""
    ) -> HtmlReport:
        """Embed image bytes (PNG, JPEG, GIF, SVG) as a data URI."""
        b64 = base64.b64encode(data).decode("ascii")
        self._n_fig += 1
        cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
        self._body.append(
            f'<figure><img alt="{html.escape(alt or caption or "figure")}" '
            f'src="data:{mime};base64,{b64}">{cap}</figure>'
        )
        return self

    def figure(
        self, fig: Any, *, caption: str | None = None, dpi: int = 110, close: bool = True
    ) -> HtmlReport:
        """Embed a Matplotlib figure as PNG.

        A figure made with :mod:`matplotlib.pyplot` is closed afterwards unless
        ``close=False``; a bare :class:`matplotlib.figure.Figure` needs no closing.
        """
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
        if close and getattr(fig.canvas, "manager", None) is not None:
            import matplotlib.pyplot as plt

            plt.close(fig)
        return self.image(buf.getvalue(), "image/png", caption=caption)

    def animation(
        self,
        data: bytes | str | os.PathLike,
        mime: str | None = None,
        *,
        caption: str | None = None,
    ) -> HtmlReport:
        """Embed a GIF (as an image) or an MP4/WebM (as a looping video).

        ``data``: bytes (then ``mime`` is required) or a file path (type from its
        extension).
        """
        if not isinstance(data, bytes):
            path = Path(data)
            ext = path.suffix.lower()
            mime = mime or {".gif": "image/gif", ".mp4": "video/mp4", ".webm": "video/webm"}.get(
                ext
            )
            if mime is None:
                raise ValueError(f"{path}: unknown animation type {ext!r} (gif, mp4, webm)")
            data = path.read_bytes()
        if mime is None:
            raise ValueError("mime is required for animation bytes")
        if mime.startswith("image/"):
            return self.image(data, mime, caption=caption)
        b64 = base64.b64encode(data).decode("ascii")
        cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
        self._body.append(
            f"<figure><video controls autoplay loop muted playsinline "
            f'src="data:{mime};base64,{b64}"></video>{cap}</figure>'
        )
        return self

    # -- output ----------------------------------------------------------------------
    def render(self) -> str:
        """The whole page."""
        from thermoswarm import __version__

        sub = f"<p>{html.escape(self.subtitle)}</p>" if self.subtitle else ""
        nav = ""
        if self.toc and len(self._sections) > 1:
            items = "".join(
                f'<li><a href="#{a}">{html.escape(t)}</a></li>' for a, t in self._sections
            )
            nav = f"<nav><ul>{items}</ul></nav>"
        return (
            '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{html.escape(self.title)}</title><style>{_CSS}</style></head><body>"
            f"<h1>{html.escape(self.title)}</h1>{sub}"
            f'<p class="note">Generated by thermoswarm {__version__}.</p>{nav}'
            + "\n".join(self._body)
            + "</body></html>\n"
        )

    def write(self, path: str | os.PathLike) -> Path:
        """Write the page to ``path`` atomically."""
        path = Path(path)
        atomic_write_text(path, self.render())
        return path
