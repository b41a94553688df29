"""The default executor of a sweep: local worker processes, each on its own.

:class:`concurrent.futures.ProcessPoolExecutor` treats the death of one worker process
as the death of the pool: every task in flight fails with ``BrokenProcessPool`` and the
pool takes no more work, so one crashed run would cost every other run in flight an
attempt.  The standard library has no pool that isolates a death, and the libraries that
do (Dask's ``LocalCluster``) start a scheduler; so :class:`LocalPool` keeps ``n`` slots,
each a single-process ``ProcessPoolExecutor`` that runs one task at a time.  A process
that dies fails only the task it was running (with :class:`WorkerDied`); its slot starts
a new process for the next task.

Worker processes are spawned (forking a process that has started OpenMP threads can
hang) with the environment variables in ``env`` set, e.g. ``NUMBA_NUM_THREADS``, which
Numba reads when it is first imported, and end when the process that started them ends.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from concurrent.futures import wait as futures_wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from typing import Any

__all__ = ["LocalPool", "WorkerDied"]


def _exit_with_parent(parent: int) -> None:
    """Worker initializer: end this process when its parent is gone (a sweep killed
    with SIGKILL would otherwise leave its workers running, orphaned, for ever)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


class WorkerDied(RuntimeError):
    """The worker process running a task ended before the task did (killed, crashed)."""


_ENV_LOCK = threading.Lock()


@contextmanager
def _environ(env: Mapping[str, str]) -> Iterator[None]:
    # A spawned child inherits the parent's environment at the moment it starts; set
    # ``env`` for that moment only.
    with _ENV_LOCK:
        old = {k: os.environ.get(k) for k in env}
        os.environ.update(env)
        try:
            yield
        finally:
            for k, v in old.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v


class LocalPool(Executor):
    """``max_workers`` local processes; a process that dies fails only its own task.

    Parameters
    ----------
    max_workers : int
        Processes (slots); each runs one task at a time.
    env : mapping, optional
        Environment variables set in every worker process from its start.
    """

    def __init__(self, max_workers: int, *, env: Mapping[str, str] | None = None) -> None:
        if max_workers < 1:
            raise ValueError(f"max_workers must be at least 1, got {max_workers}")
        self._env = {k: str(v) for k, v in (env or {}).items()}
        self._slots: list[ProcessPoolExecutor | None] = [None] * max_workers
        self._busy = [False] * max_workers
        self._queue: deque[tuple[Future, Callable, tuple, dict]] = deque()
        self._running: set[Future] = set()
        self._lock = threading.RLock()
        self._closed = False
        self.deaths = 0  # worker processes that died under a task

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> Future:
        with self._lock:
            if self._closed:
                raise RuntimeError("cannot schedule new futures after shutdown")
            fut: Future = Future()
            self._queue.append((fut, fn, args, kwargs))
            self._dispatch()
            return fut

    def _dispatch(self) -> None:  # with self._lock held
        for i in range(len(self._slots)):
            while not self._busy[i] and self._queue:
                fut, fn, args, kwargs = self._queue.popleft()
                if not fut.set_running_or_notify_cancel():
                    continue
                self._busy[i] = True
                self._running.add(fut)
                ex = self._slots[i]
                if ex is None:
                    ex = self._slots[i] = ProcessPoolExecutor(
                        1,
                        mp_context=multiprocessing.get_context("spawn"),
                        initializer=_exit_with_parent,
                        initargs=(os.getpid(),),
                    )
                    with _environ(self._env):  # the process starts at its first submit
                        inner = ex.submit(fn, *args, **kwargs)
                else:
                    inner = ex.submit(fn, *args, **kwargs)
                inner.add_done_callback(lambda f, i=i, outer=fut: self._done(i, outer, f))

    def _done(self, i: int, outer: Future, inner: Future) -> None:
        exc = inner.exception()
        with self._lock:
            if isinstance(exc, BrokenProcessPool):
                self.deaths += 1
                dead, self._slots[i] = self._slots[i], None
                if dead is not None:
                    dead.shutdown(wait=False)
                exc = WorkerDied(f"worker process died ({exc})")
            self._busy[i] = False
            self._running.discard(outer)
        if exc is not None:
            outer.set_exception(exc)
        else:
            outer.set_result(inner.result())
        with self._lock:
            self._dispatch()

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        with self._lock:
            self._closed = True
            if cancel_futures or not wait:  # nothing would start the queued tasks
                while self._queue:
                    self._queue.popleft()[0].cancel()
            pending = [q[0] for q in self._queue] + list(self._running)
        if wait:
            futures_wait(pending)
        with self._lock:
            slots = [s for s in self._slots if s is not None]
        for ex in slots:
            ex.shutdown(wait=wait, cancel_futures=cancel_futures)
