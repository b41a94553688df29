"""Atomic file writes and output-directory checks.

Outputs are written to a temporary file in the destination directory and moved into
place with :func:`os.replace`, which is atomic on POSIX and Windows: a reader sees
either the old file or the whole new one, never a half-written file.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from thermoswarm.errors import InputError, OutputError

_KINDS = {
    stat.S_IFIFO: "a FIFO",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
}


def check_replaceable(path: str | os.PathLike) -> Path:
    """Check that writing ``path`` atomically replaces nothing but a file or a folder.

    A FIFO, a device or a socket (or a link to one) at ``path`` would be replaced by
    the rename of :func:`atomic_path`: that is refused with a one-line
    :class:`OutputError`.  A missing ``path`` is fine.
    """
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return path
    except OSError as exc:
        raise OutputError(f"{path}: cannot be written ({exc.strerror or exc})") from None
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        kind = _KINDS.get(stat.S_IFMT(mode), "not a regular file")
        raise OutputError(
            f"{path} is {kind}, not a regular file: refusing to replace it (write to a file)"
        )
    return path


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path next to ``path``; move it onto ``path`` on success.

    The temporary may be a file or a directory (for Zarr stores).  On error it is
    removed and ``path`` is left untouched.  A FIFO, device or socket at ``path`` is
    never replaced (:func:`check_replaceable`), neither before nor at the rename.
    """
    path = check_replaceable(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix + ".tmp", dir=path.parent)
    os.close(fd)
    os.unlink(tmp)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        check_replaceable(path)  # it may have appeared while the output was written
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        os.replace(tmp_path, path)
    except BaseException:
        if tmp_path.is_dir():
            shutil.rmtree(tmp_path, ignore_errors=True)
        else:
            with contextlib.suppress(FileNotFoundError):
                tmp_path.unlink()
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (fsync before the rename)."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def _json_default(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return None if not np.isfinite(obj) else float(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot serialise {type(obj).__name__} to JSON")


def _finite(obj: Any) -> Any:
    """Replace non-finite floats by None so that the JSON is standard."""
    if isinstance(obj, float):
        return obj if obj == obj and obj not in (float("inf"), float("-inf")) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite(v) for v in obj]
    return obj


def dumps_json(obj: Any) -> str:
    """Serialise ``obj`` (NumPy scalars and arrays allowed) as standard JSON."""
    return json.dumps(_finite(json.loads(json.dumps(obj, default=_json_default))), indent=2)


def atomic_write_json(path: str | os.PathLike, obj: Any) -> None:
    """Write ``obj`` as indented JSON, atomically; NaN and inf become null."""
    atomic_write_text(path, dumps_json(obj) + "\n")


def check_output_dir(path: str | os.PathLike) -> Path:
    """Check, without creating anything, that ``path`` can become an output directory.

    Missing parents are fine (they are created, as ``mkdir -p`` does); the nearest
    existing ancestor must be a writable directory and ``path`` itself, if it exists,
    a directory.  Raises :class:`OutputError` with a one-line message.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"output path {str(path)!r} exists and is not a directory")
    ancestor = path.absolute().parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise OutputError(
            f"output directory {str(path)!r}: {str(ancestor)!r} is a file, not a directory"
        )
    if not os.access(ancestor, os.W_OK):
        raise OutputError(f"output directory {str(path)!r}: {str(ancestor)!r} is not writable")
    return path


def prepare_output_dir(path: str | os.PathLike, *, exist_ok: bool = True) -> Path:
    """Check that ``path`` can be an output directory (:func:`check_output_dir`) and
    create it with its missing parents.  Raises :class:`OutputError` with a one-line
    message.
    """
    path = check_output_dir(path)
    if path.exists() and not exist_ok:
        raise OutputError(f"output directory {str(path)!r} already exists")
    path.mkdir(parents=True, exist_ok=True)
    return path


def require_input(*paths: str | os.PathLike | None) -> None:
    """A missing input file is a one-line :class:`InputError` (``None`` entries are
    skipped); light enough to call before any heavy module is imported."""
    for path in paths:
        if path is not None and not Path(path).exists():
            raise InputError(f"{path}: no such file or directory")
