"""The sweep's results as one tidy table: ``OUT/results.parquet``, one row per run.

Columns: ``run_id``, ``scenario``, ``seed``, ``status``, ``error``, ``attempts``, then
every parameter of the run's resolved configuration as ``params.<dotted key>`` and
every metric as ``metrics.<dotted key>`` (nested sections flattened; a list of numbers
stays a list; a value that fits no column type is stored as JSON text).  A run that
failed has its error and null metrics.  ``pandas.read_parquet`` opens it directly
(``dask.dataframe.read_parquet`` too).

The table is rewritten atomically as runs finish (at most a tenth of the parent's time
goes to writing it), so a sweep killed at any moment leaves a readable table of what had
finished shortly before; every finished run also keeps its own ``metrics.json``, and the
next start of the sweep skips it and puts it back in the table.  Needs ``pyarrow``
(``pip install 'thermoswarm[sweep]'``); without it the table is not written.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from thermoswarm.config import to_dict
from thermoswarm.fsutil import atomic_path
from thermoswarm.sweep.spec import RunRecord

__all__ = ["ResultsTable", "TABLE_NAME", "flatten"]

TABLE_NAME = "results.parquet"
_FIXED = ("run_id", "scenario", "seed", "status", "error", "attempts")


def flatten(data: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` as ``{"a.b": 1}`` (keys prefixed by ``prefix``)."""
    out: dict[str, Any] = {}
    for k, v in data.items():
        if isinstance(v, Mapping):
            out.update(flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def _column(pa: Any, values: list[Any]) -> Any:
    """An Arrow array of ``values``; JSON text where they fit no single Arrow type."""
    try:
        return pa.array(values, from_pandas=True)
    except (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError, TypeError):
        return pa.array([None if v is None else json.dumps(v) for v in values], pa.string())


class ResultsTable:
    """Rows of a sweep, written to ``out/results.parquet`` as they come.

    Parameters
    ----------
    out : Path
        The sweep directory.
    scenario : str
    params : mapping run_id -> validated parameters (a dataclass)
        Every run of the sweep, in the order of its rows.
    """

    def __init__(self, out: Path, scenario: str, params: Mapping[str, Any]) -> None:
        self.path = Path(out) / TABLE_NAME
        self.scenario = scenario
        self._params = {rid: flatten(to_dict(p), "params.") for rid, p in params.items()}
        self._rows: dict[str, dict[str, Any]] = {}
        self._dirty = False
        self._last_write = -math.inf
        self._write_seconds = 0.0
        try:
            import pyarrow
            import pyarrow.parquet
        except ImportError:
            self._pa = None
            self.unavailable = "pyarrow is not installed (pip install 'thermoswarm[sweep]')"
        else:
            self._pa = pyarrow
            self._pq = pyarrow.parquet
            self.unavailable = None

    def add(self, rec: RunRecord) -> None:
        """Set the row of ``rec`` (replacing an earlier row of the same run)."""
        row: dict[str, Any] = {
            "run_id": rec.run_id,
            "scenario": self.scenario,
            "seed": rec.seed,
            "status": rec.status,
            "error": rec.error,
            "attempts": rec.attempts,
        }
        row.update(self._params.get(rec.run_id, {}))
        row.update(flatten(rec.metrics or {}, "metrics."))
        self._rows[rec.run_id] = row
        self._dirty = True

    def __len__(self) -> int:
        return len(self._rows)

    def maybe_write(self) -> None:
        """Write if rows changed and writing has taken under a tenth of the time since
        the last write (each write is the whole table: O(rows))."""
        if self._dirty and time.perf_counter() - self._last_write >= 10 * self._write_seconds:
            self.write()

    def write(self) -> None:
        """Write the table now (atomically) if pyarrow is there and rows changed."""
        if self._pa is None or not self._dirty:
            return
        t0 = time.perf_counter()
        rows = [self._rows[rid] for rid in self._params if rid in self._rows]  # spec order
        names = list(_FIXED)
        extra = sorted({k for r in rows for k in r} - set(_FIXED))
        names += [k for k in extra if k.startswith("params.")]
        names += [k for k in extra if not k.startswith("params.")]
        table = self._pa.table({k: _column(self._pa, [r.get(k) for r in rows]) for k in names})
        with atomic_path(self.path, suffix=".parquet") as tmp:
            self._pq.write_table(table, tmp)
        self._dirty = False
        self._last_write = time.perf_counter()
        self._write_seconds = self._last_write - t0
