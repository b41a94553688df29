"""Dependencies run one way: library -> studies -> report -> reproduce -> CLI.

Every ``import`` statement of the package is read from the source (function-level
imports included, which an import-time check would miss), and the test fails when a
lower layer imports a higher one.
"""

from __future__ import annotations

import ast
from pathlib import Path

import thermoswarm

ROOT = Path(thermoswarm.__file__).parent


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_of(path: Path) -> set[str]:
    """Every ``thermoswarm...`` module named by an import in ``path`` (absolute names)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    here = _module_name(path)
    package = here if path.name == "__init__.py" else here.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            found.add(mod)
            found.update(f"{mod}.{a.name}" for a in node.names)
    return {m for m in found if m == "thermoswarm" or m.startswith("thermoswarm.")}


def _graph() -> dict[str, set[str]]:
    return {_module_name(p): imports_of(p) for p in ROOT.rglob("*.py")}


def _in(module: str, layer: str) -> bool:
    return module == layer or module.startswith(layer + ".")


# layer -> the layers above it, which it must never import
FORBIDDEN = {
    "thermoswarm.studies": ["thermoswarm.cli", "thermoswarm.reproduce", "thermoswarm.report"],
    "thermoswarm.report": ["thermoswarm.cli", "thermoswarm.reproduce"],
    "thermoswarm.reproduce": ["thermoswarm.cli"],
}


def test_the_scanner_sees_function_level_and_relative_imports():
    src = ROOT / "cli" / "study.py"
    got = imports_of(src)
    # cli/study.py imports the studies only inside its commands
    assert any(_in(m, "thermoswarm.studies") for m in got), got


def test_no_module_below_the_cli_imports_the_cli():
    graph = _graph()
    bad = sorted(
        (mod, imp)
        for mod, imps in graph.items()
        if not _in(mod, "thermoswarm.cli") and mod != "thermoswarm.__main__"
        for imp in imps
        if _in(imp, "thermoswarm.cli")
    )
    assert not bad, f"imports of the CLI from below it: {bad}"


def test_layers_never_import_the_layers_above_them():
    graph = _graph()
    bad = sorted(
        (mod, imp)
        for layer, above in FORBIDDEN.items()
        for mod, imps in graph.items()
        if _in(mod, layer)
        for imp in imps
        for up in above
        if _in(imp, up)
    )
    assert not bad, f"imports against the layering: {bad}"
