"""``make run``'s estimates of what is left beside the time the run really took.

Reads the log of a ``thermoswarm reproduce`` whose every line carries the Unix time it
was printed (the shell loop below), and prints one row per finished step: the time
since the start, the estimate printed ("about ... left"), the time the run then really
took to its end (the "wrote ..." line) and their ratio; then the worst ratio from the
first estimate on and from the second.  Issue 33 asks for every ratio within 1.5x.

Usage::

    PYTHONPATH=$PWD/src .venv/bin/python -m thermoswarm reproduce --quick --out /tmp/run \\
      2>&1 | while IFS= read -r l; do echo "$(date +%s.%N) $l"; done > /tmp/run.log
    python benchmarks/progress_table.py /tmp/run.log
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

_STEP = re.compile(
    r"^(\S+) \[\s*(.+?)\] (\d+)/(\d+) (\S+) done in (.+?)(?:; about (.+?) left.*)?$"
)
_END = re.compile(r"^(\S+) wrote .* in (.+)$")


def seconds(text: str) -> float:
    """Seconds of a duration as the progress log prints it ("1 h 02 min", "3 min 04 s",
    "42 s")."""
    total = 0.0
    for value, unit in re.findall(r"(\d+(?:\.\d+)?) (h|min|s)\b", text):
        total += float(value) * {"h": 3600, "min": 60, "s": 1}[unit]
    return total


def rows(lines: list[str]) -> list[dict[str, float | str]]:
    """One row per finished step with an estimate; the ratio estimate / truth."""
    steps, end = [], None
    for line in lines:
        if m := _STEP.match(line):
            steps.append((float(m[1]), int(m[3]), m[5], seconds(m[6]), m[7]))
        elif m := _END.match(line):
            end = float(m[1])
    if end is None:
        raise SystemExit(
            "error: the log has no final 'wrote ... in ...' line (did the run finish?)"
        )
    start = steps[0][0] - steps[0][3] if steps else end
    out: list[dict[str, float | str]] = []
    for t, k, name, took, left in steps:
        if left is None:
            continue
        truth = end - t
        est = seconds(left)
        out.append({"step": f"{k} {name}", "at_s": t - start, "took_s": took,
                    "estimate_s": est, "actual_s": truth, "ratio": est / truth})  # fmt: skip
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("log", type=Path, help="a reproduce log with a Unix time before each line")
    args = ap.parse_args(argv)
    try:
        table = rows(args.log.read_text().splitlines())
    except OSError as exc:
        print(f"error: cannot read {args.log}: {exc.strerror}", file=sys.stderr)
        return 2
    print("| after step | at (s) | step took (s) | estimate left (s) | actual left (s) | ratio |")
    print("|---|---|---|---|---|---|")
    for r in table:
        print(f"| {r['step']} | {r['at_s']:.0f} | {r['took_s']:.0f} | {r['estimate_s']:.0f} | "
              f"{r['actual_s']:.0f} | {r['ratio']:.2f} |")  # fmt: skip
    worst = [max(r["ratio"], 1 / r["ratio"]) for r in table]  # type: ignore[arg-type]
    if worst:
        print(f"worst factor from the first estimate on: {max(worst):.2f}")
        if len(worst) > 1:
            print(f"worst factor from the second step on: {max(worst[1:]):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
