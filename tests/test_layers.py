"""Dependencies run one way, and no module imports itself back through others.

The graph is every import statement of the package, at any depth (function-level
imports included, ``if TYPE_CHECKING:`` blocks left out), as grimp builds it, plus the
imports done by name at run time: a string constant (not a docstring) that names one of
the package's modules, ``"pkg.mod"`` or ``"pkg.mod:attr"``, as the registries pass to
``importlib.import_module`` (grimp cannot see those).  A cycle is a strongly connected
component of more than one module.

The layers, bottom to top: the law and the simulator; the analysis; the scenarios; the
sweeps and the studies; the report; ``reproduce``; the CLI.  Each rule below names what
a layer must never import.

Inside ``tracking``, the rooms (``thermoswarm/tracking/__init__.py`` draws them): the floor
(``anatomy``, ``detection``, ``video``, ``evaluate``); ``synth``, ``detect`` and ``track``,
which never import each other; ``train``; ``pipeline``; and ``batch`` (many videos through
the pipeline) at the top.
"""

from __future__ import annotations

import ast
import importlib.util
import sys
from pathlib import Path

import grimp
import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

#: layer -> the modules above it that it must never import (prefixes)
FORBIDDEN = {
    "thermoswarm.analysis": ("thermoswarm.report", "thermoswarm.cli", "thermoswarm.io",
                             "thermoswarm.sim", "thermoswarm.scenarios"),
    "thermoswarm.sim": ("thermoswarm.sweep", "thermoswarm.scenarios", "thermoswarm.studies",
                        "thermoswarm.report", "thermoswarm.reproduce", "thermoswarm.cli"),
    "thermoswarm.scenarios": ("thermoswarm.sweep", "thermoswarm.studies",
                              "thermoswarm.reproduce", "thermoswarm.cli"),
    "thermoswarm.studies": ("thermoswarm.cli", "thermoswarm.reproduce", "thermoswarm.report"),
    "thermoswarm.report": ("thermoswarm.cli", "thermoswarm.reproduce"),
    "thermoswarm.reproduce": ("thermoswarm.cli",),
}  # fmt: skip

_T = "thermoswarm.tracking."
#: the tracking rooms, bottom to top: each tuple is one rank
TRACKING_RANKS = (
    ("anatomy", "detection", "video", "evaluate"),
    ("synth", "detect", "track"),
    ("train",),
    ("pipeline",),
    ("batch",),
)
for _rank, _rooms in enumerate(TRACKING_RANKS):
    _above = [r for rooms in TRACKING_RANKS[_rank + 1 :] for r in rooms]
    for _room in _rooms:
        # a room imports neither a room above it nor another room of its own rank
        _others = [r for r in _rooms if r != _room] if _rank else []
        FORBIDDEN[_T + _room] = tuple(_T + r for r in _above + _others)


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports_by_name(root: Path, modules: set[str]) -> dict[tuple[str, str], list[str]]:
    """Edges from string constants that name a module of the package, with where."""
    found: dict[tuple[str, str], list[str]] = {}
    for path in sorted(root.rglob("*.py")):
        me = _module_name(path, root)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docs = {
            id(node.value)
            for node in ast.walk(tree)
            if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
        }
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                name = node.value.split(":")[0]
                if id(node) not in docs and "." in name and name in modules and name != me:
                    where = f"{path.relative_to(root.parent)}:{node.lineno} (by name)"
                    found.setdefault((me, name), []).append(where)
    return found


def import_cycles(package: str) -> list[list[tuple[str, str, list[str]]]]:
    """Each cycle of ``package``'s import graph as its edges ``(importer, imported,
    [file:line, ...])``, modules sorted; an empty list when the graph is acyclic."""
    edges = import_edges(package)
    modules = sorted({m for e in edges for m in e})
    index = {m: i for i, m in enumerate(modules)}
    rows = [index[a] for a, _ in edges]
    cols = [index[b] for _, b in edges]
    adj = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(modules),) * 2)
    _, label = connected_components(adj, directed=True, connection="strong")
    cycles = []
    for c in np.unique(label):
        members = {modules[i] for i in np.flatnonzero(label == c)}
        if len(members) > 1:
            inner = sorted(
                (a, b, w) for (a, b), w in edges.items() if a in members and b in members
            )
            cycles.append(inner)
    return sorted(cycles)


def describe(cycles) -> str:
    lines = []
    for inner in cycles:
        members = sorted({a for a, _, _ in inner})
        lines.append(f"cycle of {len(members)} modules: {', '.join(members)}")
        lines += [f"    {a} -> {b}  [{'; '.join(w)}]" for a, b, w in inner]
    return "\n".join(lines)


def import_edges(package: str) -> dict[tuple[str, str], list[str]]:
    """Every edge ``(importer, imported) -> [file:line, ...]`` of ``package``."""
    root = Path(importlib.util.find_spec(package).origin).parent
    graph = grimp.build_graph(package, exclude_type_checking_imports=True, cache_dir=None)
    files = {_module_name(f, root): f.relative_to(root.parent) for f in root.rglob("*.py")}
    edges: dict[tuple[str, str], list[str]] = {}
    for m in graph.modules:
        for t in graph.find_modules_directly_imported_by(m):
            details = graph.get_import_details(importer=m, imported=t)
            edges[(m, t)] = [f"{files[m]}:{d['line_number']}" for d in details] or ["?"]
    for edge, where in _imports_by_name(root, set(graph.modules)).items():
        edges.setdefault(edge, []).extend(where)
    return edges


def _in(module: str, prefix: str) -> bool:
    return module == prefix or module.startswith(prefix + ".")


@pytest.fixture(scope="module")
def edges():
    return import_edges("thermoswarm")


def test_no_import_cycle():
    cycles = import_cycles("thermoswarm")
    assert not cycles, "import cycles:\n" + describe(cycles)


def test_no_layer_imports_a_layer_above_it(edges):
    bad = sorted(
        f"{a} -> {b}  [{'; '.join(w)}]"
        for (a, b), w in edges.items()
        for layer, above in FORBIDDEN.items()
        if _in(a, layer) and any(_in(b, up) for up in above)
    )
    assert not bad, "imports against the layering:\n" + "\n".join(bad)


def test_every_tracking_room_has_a_rank():
    """A new module or subpackage of ``tracking`` must be placed in a rank, or the layer
    rules above would not see it."""
    root = Path(importlib.util.find_spec("thermoswarm.tracking").origin).parent
    rooms = {p.stem for p in root.glob("*.py") if p.stem != "__init__"}
    rooms |= {p.parent.name for p in root.glob("*/__init__.py")}
    ranked = {r for rooms_ in TRACKING_RANKS for r in rooms_}
    assert rooms == ranked, f"unranked: {sorted(rooms - ranked)}; gone: {sorted(ranked - rooms)}"


def test_the_tracking_rooms_forbid_their_neighbours():
    """The rule table itself: ``track`` may not import ``detect`` (same rank), ``synth``
    may not import ``train`` (above), ``train`` may import ``detect`` (below)."""
    assert _T + "detect" in FORBIDDEN[_T + "track"]
    assert _T + "train" in FORBIDDEN[_T + "synth"]
    assert _T + "detect" not in FORBIDDEN[_T + "train"]
    assert _T + "pipeline" in FORBIDDEN[_T + "anatomy"]


def test_nothing_below_the_cli_imports_it(edges):
    bad = sorted(
        f"{a} -> {b}  [{'; '.join(w)}]"
        for (a, b), w in edges.items()
        if _in(b, "thermoswarm.cli") and not _in(a, "thermoswarm.cli")
        and a != "thermoswarm.__main__"
    )  # fmt: skip
    assert not bad, "imports of the CLI from below it:\n" + "\n".join(bad)


def test_the_graph_sees_function_level_imports(edges):
    # cli/study.py imports the studies only inside its commands
    assert any(_in(a, "thermoswarm.cli.study") and _in(b, "thermoswarm.studies") for a, b in edges)


def test_the_check_finds_hidden_cycles(tmp_path, monkeypatch):
    """A cycle through a function-level import, one through an import by name, and a
    module that mentions another only in its docstring (no edge)."""
    pkg = tmp_path / "cyclepkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("import cyclepkg.b\n")
    (pkg / "b.py").write_text("def f():\n    from cyclepkg import a\n")
    (pkg / "c.py").write_text('PLUGINS = {"d": "cyclepkg.d:make"}\n')
    (pkg / "d.py").write_text('"""See cyclepkg.e."""\nfrom cyclepkg.c import PLUGINS\n')
    (pkg / "e.py").write_text("import cyclepkg.d\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        found = import_cycles("cyclepkg")
    finally:
        for name in [m for m in sys.modules if m.startswith("cyclepkg")]:
            del sys.modules[name]
    members = [sorted({a for a, _, _ in inner}) for inner in found]
    assert members == [["cyclepkg.a", "cyclepkg.b"], ["cyclepkg.c", "cyclepkg.d"]]
    assert "cyclepkg/b.py:2" in describe(found)
    assert "(by name)" in describe(found)
