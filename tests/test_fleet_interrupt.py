"""Ctrl-C and kill during a fleet on local worker processes: the command stops at once, leaves no worker behind and
prints no traceback (a Ctrl-C could leave it waiting for ever on a worker stuck on the pool's lock, or print a
KeyboardInterrupt traceback; SIGTERM to the command alone left its two workers running)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from roadbank.fleet.cluster import OnProcesses

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="process groups and prctl: Linux")


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return [int(x) for x in out.split()]


def test_pool_workers_leave_ctrl_c_to_the_command_and_end_with_it():
    """Each worker ignores SIGINT (the command stops the pool; that they end with it, the test below), and
    :meth:`OnProcesses.abort` ends them at once."""
    pool = OnProcesses(2)
    try:
        handlers = [pool.submit(signal.getsignal, signal.SIGINT).result(timeout=60) for _ in range(4)]
        assert all(h == signal.SIG_IGN for h in handlers)
    finally:
        pool.abort()
    assert not any(p.is_alive() for p in (pool._ex._processes or {}).values())


def _fleet(d, n: int = 40, rows: int = 60000) -> None:
    t = np.arange(rows) * 0.01
    body = "\n".join(f"{a:.2f},20,{0.3 * np.sin(a):.6f},{0.015 * np.sin(a):.6f},0" for a in t)
    for i in range(n):
        (d / f"log{i:02d}.csv").write_text("t,vx,ay,r,delta_f\n" + body + "\n")


@pytest.mark.slow
@pytest.mark.parametrize("how", ["ctrl-c", "sigterm"])
def test_an_interrupted_fleet_stops_at_once_and_leaves_no_worker(tmp_path, how):
    """``roadbank estimate DIR --workers 2`` stopped once its workers run: Ctrl-C (SIGINT to the process group, as a
    terminal sends it) or SIGTERM to the command alone (a job scheduler). It ends within seconds, without a
    traceback, and no worker process survives it."""
    d = tmp_path / "logs"
    d.mkdir()
    _fleet(d)
    def defaults() -> None:     # as a terminal starts a command (a test runner's process may ignore either)
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)

    p = subprocess.Popen([sys.executable, "-m", "roadbank.cli", "estimate", str(d), "-e", "kinematic", "-o",
                          str(tmp_path / "out"), "--workers", "2"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         text=True, start_new_session=True, cwd=tmp_path, preexec_fn=defaults)
    summary = tmp_path / "out" / "summary.csv"
    deadline = time.monotonic() + 300              # the workers started and warmed: a log finished
    while p.poll() is None and time.monotonic() < deadline and not (
            summary.exists() and len(summary.read_text().splitlines()) >= 2):
        time.sleep(0.2)
    workers = _children(p.pid)
    assert p.poll() is None and len(workers) >= 2, "the fleet ended before it could be interrupted"
    if how == "ctrl-c":
        os.killpg(p.pid, signal.SIGINT)
    else:
        os.kill(p.pid, signal.SIGTERM)
    try:
        err = p.communicate(timeout=60)[1]
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        pytest.fail("the command did not stop within 60 s")
    assert p.returncode == (130 if how == "ctrl-c" else -signal.SIGTERM) and "Traceback" not in err, (p.returncode, err)
    deadline = time.monotonic() + 15
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not any(_alive(w) for w in workers), "a worker outlived the command"
