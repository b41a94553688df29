"""The sizes a newcomer meets: the largest files and the functions over a length.

Reads every ``.py`` file under the given roots (default ``src/thermoswarm``) with
:mod:`ast` and prints the ``--files`` largest files (lines) and every function or
method longer than ``--max`` lines (from its ``def`` line to its last line,
decorators not counted; nested functions listed on their own too), longest first,
with the median length of all functions.

Usage::

    python tools/code_size.py                 # functions over 80 lines
    python tools/code_size.py --max 120 src/thermoswarm/tracking
"""

from __future__ import annotations

import argparse
import ast
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def functions(path: Path) -> list[tuple[int, str, int]]:
    """``(lines, qualified name, first line)`` of every function in ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: list[tuple[int, str, int]] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = prefix + child.name
                out.append((child.end_lineno - child.lineno + 1, name, child.lineno))
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(tree, "")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("roots", nargs="*", type=Path, default=[ROOT / "src" / "thermoswarm"])
    ap.add_argument("--max", type=int, default=80, help="list functions longer than this")
    ap.add_argument("--files", type=int, default=5, help="how many of the largest files")
    args = ap.parse_args(argv)
    files = sorted({p for r in args.roots for p in ([r] if r.is_file() else r.rglob("*.py"))})
    sizes, funcs = [], []
    for f in files:
        rel = f.resolve().relative_to(ROOT) if f.resolve().is_relative_to(ROOT) else f
        sizes.append((len(f.read_text(encoding="utf-8").splitlines()), str(rel)))
        funcs += [(n, f"{rel}:{line} {name}") for n, name, line in functions(f)]
    print(f"{len(files)} files, {len(funcs)} functions; median function "
          f"{statistics.median(n for n, _ in funcs):.0f} lines")  # fmt: skip
    print("largest files:")
    for n, rel in sorted(sizes, reverse=True)[: args.files]:
        print(f"  {n:5d}  {rel}")
    long_ = sorted((f for f in funcs if f[0] > args.max), reverse=True)
    print(f"functions over {args.max} lines: {len(long_)}")
    for n, where in long_:
        print(f"  {n:5d}  {where}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
