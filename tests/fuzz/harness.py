"""Run a verb in this process as a user would, and say how it ended.

:func:`outcome` calls :func:`thermoswarm.cli.main` with ``argv`` under a wall-clock
alarm and classifies the end:

- ``"ok"``: exit status 0;
- ``"error"``: exit status 2 and stderr's last line ``error: ...`` (one line, no
  traceback, no ``np.float64(`` repr), or click's own usage error (``Usage: ...``
  then ``Error: ...``);
- ``"traceback"``: any other exception, exit status, or an error message of several
  lines or with a traceback;
- ``"hang"``: the alarm rang (``limit_s``);
- ``"memory"``: a ``MemoryError`` (NumPy's ``_ArrayMemoryError`` included).

:data:`COUNTS` tallies every run per verb (runs, clean errors, correct results,
tracebacks, hangs, memory blow-ups); ``tests/fuzz/conftest.py`` prints the table at
the end of the session.
"""

from __future__ import annotations

import contextlib
import io
import signal
from collections import defaultdict
from dataclasses import dataclass

#: verb -> kind -> runs
COUNTS: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))


class _Alarm(BaseException):
    """Raised by SIGALRM (a BaseException: no ``except Exception`` swallows it)."""


@dataclass
class Outcome:
    kind: str
    code: int | None
    out: str
    err: str

    def __str__(self) -> str:
        return f"{self.kind} (exit {self.code}): {self.err[-2000:]}"


def _on_alarm(signum, frame):  # pragma: no cover - only when a run hangs
    raise _Alarm()


def outcome(argv: list[str], *, limit_s: int = 60) -> Outcome:
    """Run ``thermoswarm ARGV`` here; classify how it ended (see the module docstring)."""
    from thermoswarm.cli import main

    out, err = io.StringIO(), io.StringIO()
    code: int | None = None
    kind = ""
    old = signal.signal(signal.SIGALRM, _on_alarm)
    signal.alarm(limit_s)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                main([str(a) for a in argv])
                code = 0
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except _Alarm:
        kind = "hang"
    except MemoryError:
        kind = "memory"
    except Exception as exc:  # noqa: BLE001 - the point: any exception is a finding
        import traceback

        kind = "traceback"
        err.write("".join(traceback.format_exception(exc)))
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    text = err.getvalue()
    if not kind:
        lines = [ln for ln in text.splitlines() if ln.strip()]
        clean = (
            bool(lines)
            and lines[-1].startswith(("error: ", "Error: "))
            and "Traceback" not in text
            and "np.float64(" not in text
            and not any(ln.startswith("  File ") for ln in lines)
        )
        if code == 0:
            kind = "ok" if "Traceback" not in text else "traceback"
        elif code == 2 and clean:
            kind = "error"
        elif "MemoryError" in text:
            kind = "memory"
        else:
            kind = "traceback"
    return Outcome(kind, code, out.getvalue(), text)


def record(verb: str, result: Outcome, *, correct: bool | None = None) -> None:
    """Count ``result`` under ``verb``; ``correct`` (for an ``ok`` run) whether its
    output passed the verb's check."""
    c = COUNTS[verb]
    c["runs"] += 1
    if result.kind == "ok":
        c["correct results" if correct else "wrong results"] += 1
    elif result.kind == "error":
        c["clean errors"] += 1
    else:
        c[
            {"traceback": "tracebacks", "hang": "hangs", "memory": "memory blow-ups"}[result.kind]
        ] += 1


def assert_clean(verb: str, result: Outcome, *, correct: bool | None = None) -> None:
    """Record the run, then fail unless it ended cleanly (and, if ``ok``, correctly)."""
    record(verb, result, correct=correct)
    assert result.kind in ("ok", "error"), str(result)
    if result.kind == "ok":
        assert correct is not False, f"wrong result: {result}"
    else:
        errors = [ln for ln in result.err.splitlines() if ln.startswith(("error:", "Error:"))]
        assert len(errors) == 1, str(result)


def table() -> str:
    """The per-verb counts as a text table."""
    cols = ["runs", "clean errors", "correct results", "wrong results", "tracebacks", "hangs",
            "memory blow-ups"]  # fmt: skip
    rows = [f"{'verb':<22}" + "".join(f"{c:>17}" for c in cols)]
    for verb in sorted(COUNTS):
        rows.append(f"{verb:<22}" + "".join(f"{COUNTS[verb].get(c, 0):>17}" for c in cols))
    return "\n".join(rows)
