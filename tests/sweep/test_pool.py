"""The local pool: a worker process that dies fails its own task and nothing else."""

from __future__ import annotations

import os

import pytest

from thermoswarm.sweep.pool import LocalPool, WorkerDied


def test_a_dead_worker_fails_only_its_own_task(pool):
    deaths = pool.deaths
    before = [pool.submit(abs, -i) for i in range(6)]
    dying = pool.submit(os._exit, 3)  # the worker process ends under the task
    after = [pool.submit(abs, -i) for i in range(6, 12)]
    with pytest.raises(WorkerDied, match="worker process died"):
        dying.result(timeout=120)
    assert [f.result(timeout=120) for f in before + after] == list(range(12))
    assert pool.deaths == deaths + 1
    # its slot took a fresh process: both slots still work
    assert sorted(pool.submit(abs, -i).result(timeout=120) for i in range(4)) == [0, 1, 2, 3]


def test_shutdown_runs_what_was_queued_and_then_refuses_work():
    pool = LocalPool(1)
    futures = [pool.submit(abs, -i) for i in range(3)]
    pool.shutdown(wait=True)
    assert [f.result() for f in futures] == [0, 1, 2]
    with pytest.raises(RuntimeError, match="after shutdown"):
        pool.submit(abs, 1)


def test_workers_end_when_the_sweep_process_is_killed(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    script = tmp_path / "parent.py"
    script.write_text(
        "import os, signal, time\n"
        "from thermoswarm.sweep.pool import LocalPool\n"
        "if __name__ == '__main__':\n"
        "    pool = LocalPool(1)\n"
        "    print(pool.submit(os.getpid).result(), flush=True)\n"
        "    pool.submit(time.sleep, 600)\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=300)  # fmt: skip
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    worker = int(proc.stdout.split()[0])
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            os.kill(worker, 0)
            state = open(f"/proc/{worker}/stat").read().rsplit(")", 1)[1].split()[0]
        except (ProcessLookupError, FileNotFoundError):
            return  # the orphaned worker ended by itself
        if state == "Z":
            return  # ended, not yet reaped
        time.sleep(0.1)
    os.kill(worker, signal.SIGKILL)
    pytest.fail(f"worker {worker} outlived its parent by 60 s")
