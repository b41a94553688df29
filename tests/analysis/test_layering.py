"""Dependencies run one way: law -> fit -> study -> report -> CLI, and no import cycle.

Every import counts, at module level or inside a function (a function-level import only
hides a cycle)."""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import thermoswarm

ROOT = Path(thermoswarm.__file__).parent
#: The modules this test watches: the analysis, the readers, the trajectory format, and
#: the report modules built on the analysis.
WATCHED = ("thermoswarm.analysis", "thermoswarm.io", "thermoswarm.tracks")
EXTRA = ("thermoswarm.report.analysis_figures", "thermoswarm.report.analysis_run")


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def _imports(path: Path, name: str) -> set[str]:
    tree = ast.parse(path.read_text())
    pkg = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            for a in node.names:
                full = f"{base}.{a.name}"
                out.add(full if _is_module(full) else base)
    return {m for m in out if m.startswith("thermoswarm")}


def _graph() -> dict[str, set[str]]:
    files = [p for p in ROOT.rglob("*.py")]
    mods = {_module_name(p): p for p in files}
    watched = {
        m: p
        for m, p in mods.items()
        if m in EXTRA or any(m == w or m.startswith(w + ".") for w in WATCHED)
    }
    return {m: {d for d in _imports(p, m) if d in watched and d != m} for m, p in watched.items()}


def test_analysis_never_imports_the_report_the_cli_the_readers_or_the_simulator():
    g: dict[str, set[str]] = {}
    for path in (ROOT / "analysis").rglob("*.py"):
        name = _module_name(path)
        g[name] = _imports(path, name)
    for name, deps in g.items():
        bad = sorted(
            d
            for d in deps
            if d.startswith(("thermoswarm.report", "thermoswarm.cli", "thermoswarm.io"))
            or d.startswith(("thermoswarm.sim", "thermoswarm.scenarios"))
        )
        assert not bad, f"{name} imports {bad}"


def test_no_import_cycle():
    g = _graph()
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for d in sorted(g.get(m, ())):
            if state.get(d) == 1:
                cycle = stack[stack.index(d) :] + [d]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if d not in state:
                visit(d)
        stack.pop()
        state[m] = 2

    for m in sorted(g):
        if m not in state:
            visit(m)
