"""No import cycle in the package, type-only imports counted.

``tests/test_layers.py`` checks the layering on the imports that run (``if
TYPE_CHECKING:`` blocks left out, imports done by name added).  A cycle through a
type-only import still ties two modules together: neither can be read, moved or tested
without the other, and the first annotation evaluated at run time (``get_type_hints``,
a dataclass converter) turns it into a real cycle.  So here the graph is every import
statement grimp finds, ``TYPE_CHECKING`` blocks included, and a cycle is a strongly
connected component of more than one module.
"""

from __future__ import annotations

import grimp
import pytest


def cycles(package: str) -> list[list[str]]:
    """Each cycle of ``package``'s imports (type-only ones included): its modules, sorted."""
    graph = grimp.build_graph(package, exclude_type_checking_imports=False, cache_dir=None)
    succ = {m: sorted(graph.find_modules_directly_imported_by(m)) for m in graph.modules}
    return _strongly_connected(succ)


def _strongly_connected(succ: dict[str, list[str]]) -> list[list[str]]:
    """Tarjan's algorithm, iterative; components of more than one node, sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    for root in sorted(succ):
        if root in index:
            continue
        work = [(root, iter(succ[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            node, it = work[-1]
            nxt = next(it, None)
            if nxt is not None:
                if nxt not in index:
                    index[nxt] = low[nxt] = len(index)
                    stack.append(nxt)
                    on.add(nxt)
                    work.append((nxt, iter(succ.get(nxt, []))))
                elif nxt in on:
                    low[node] = min(low[node], index[nxt])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    m = stack.pop()
                    on.discard(m)
                    comp.append(m)
                    if m == node:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return sorted(out)


def test_no_import_cycle_counting_type_only_imports():
    found = cycles("thermoswarm")
    assert not found, "import cycles (type-only imports counted):\n" + "\n".join(
        " <-> ".join(c) for c in found
    )


@pytest.fixture
def toy_package(tmp_path, monkeypatch):
    """``toycyc``: ``a`` imports ``b`` at run time, ``b`` imports ``a`` only for types;
    ``c`` imports ``a`` (no cycle through it)."""
    pkg = tmp_path / "toycyc"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from toycyc import b\n")
    (pkg / "b.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from toycyc.a import X\n"
    )
    (pkg / "c.py").write_text("import toycyc.a\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    return "toycyc"


def test_a_type_only_cycle_is_found(toy_package):
    assert cycles(toy_package) == [["toycyc.a", "toycyc.b"]]
    # the graph of the imports that run does not see it (what test_layers.py checks)
    run_only = grimp.build_graph(toy_package, exclude_type_checking_imports=True, cache_dir=None)
    assert "toycyc.a" not in run_only.find_modules_directly_imported_by("toycyc.b")


def test_tarjan_finds_every_component():
    succ = {"a": ["b"], "b": ["c"], "c": ["a", "d"], "d": ["e"], "e": ["d"], "f": ["a"]}
    assert _strongly_connected(succ) == [["a", "b", "c"], ["d", "e"]]
    assert _strongly_connected({"a": ["a"], "b": []}) == []
