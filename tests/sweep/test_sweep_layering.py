"""Dependencies run one way: sweeps use scenarios, scenarios never use sweeps."""

from __future__ import annotations

import ast
from pathlib import Path

import thermoswarm

ROOT = Path(thermoswarm.__file__).parent


def _imports(path: Path) -> set[str]:
    """Every module a file imports, at any depth (function-level imports included)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{a.name}" for a in node.names)
    return found


def _offenders(package: str, forbidden: str) -> list[str]:
    files = sorted((ROOT / package).rglob("*.py"))
    assert files, f"no modules under {package}"
    return [
        f"{f.relative_to(ROOT)} imports {m}"
        for f in files
        for m in sorted(_imports(f))
        if m == forbidden or m.startswith(forbidden + ".")
    ]


def test_scenarios_never_import_the_sweep():
    assert _offenders("scenarios", "thermoswarm.sweep") == []


def test_the_simulator_never_imports_the_sweep():
    assert _offenders("sim", "thermoswarm.sweep") == []


def test_the_check_sees_function_level_imports(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("def g():\n    from thermoswarm.sweep import run_sweep\n")
    assert "thermoswarm.sweep" in _imports(f)
