"""MkDocs hook: the docstrings' Sphinx roles (``:func:`x```) shown as plain code.

The docstrings are numpydoc, read by mkdocstrings; its Python handler renders the
roles' text literally (":mod:" before the code), so they are dropped here, together with
Sphinx's "~" (show the last name only).
"""

import re

_ROLE = re.compile(r":(?:mod|func|class|meth|attr|data|obj|exc|py:\w+):(<code>)~?")
_TILDE = re.compile(r"<code>~([\w.]+)</code>")


def on_page_content(html, **kwargs):
    html = _ROLE.sub(r"\1", html)
    return _TILDE.sub(lambda m: "<code>" + m.group(1).rsplit(".", 1)[-1] + "</code>", html)
