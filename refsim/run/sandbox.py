"""A job in a process of its own: an engine that aborts, segfaults or hangs costs that process
and its one job, never the run.

`Sandbox` keeps one child Python process (started on demand, kept between jobs) that runs one
job at a time and sends its row back over a socket. When the child dies in a job, the job's
row says how ("worker died: SIGSEGV") and the next job gets a fresh child; when a job runs
past its timeout, the child is killed and the row is `timeout`. The local executor keeps one
Sandbox per worker; on a Dask cluster each worker thread keeps one (`dask_task`).

The child is a new interpreter (`python -c`), not a fork: it sees the parent's `sys.path`
(PYTHONPATH) and the engines, cases and benches registered at run time in the parent
(`refsim.registry.register`), which are sent with every job.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from multiprocessing.connection import Connection

PINNED = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
RUNTIME_ORIGIN = "registered at run time"


def run_task(task) -> tuple:
    """(job, row) of one task (job, run_id, repeats, budget_s); the row names its host."""
    from refsim.run.job import run_job
    job, run_id, repeats, budget_s = task
    row = run_job(job, run_id, repeats, budget_s)
    row["host"] = socket.gethostname()
    return job, row


def lost_row(task, status: str, reason: str, wall_s: float, host: str = "") -> dict:
    """The row of a job whose process died or ran out of time: no result, only why."""
    from refsim.run.job import _blank_row
    job, run_id = task[0], task[1]
    row = _blank_row(job, run_id)
    # the whole wall time went to the engine call that crashed or hung
    row.update(status=status, reason=reason, wall_s=wall_s, engine_s=wall_s, host=host)
    return row


def death_reason(returncode) -> str:
    """"worker died: SIGABRT" for a child killed by a signal, "... exit code 3" otherwise."""
    if returncode is not None and returncode < 0:
        try:
            name = signal.Signals(-returncode).name
        except ValueError:
            name = f"signal {-returncode}"
        return f"worker died: {name}"
    return f"worker died: exit code {returncode}"


def runtime_registrations() -> tuple:
    """(kind, name, target) of every registration made at run time in this process."""
    from refsim.registry import GROUPS, entries
    return tuple((kind, name, e.target) for kind in GROUPS for name, e in entries(kind).items()
                 if e.origin == RUNTIME_ORIGIN)


def child_env(pin_threads: bool) -> dict:
    """The parent's environment, its sys.path as PYTHONPATH, BLAS/OpenMP on one thread when
    `pin_threads` (several workers share the cores)."""
    env = dict(os.environ)
    paths = [p or os.getcwd() for p in sys.path]
    env["PYTHONPATH"] = os.pathsep.join(dict.fromkeys(p for p in paths if os.path.isdir(p)))
    for var in PINNED:
        env[var] = "1" if pin_threads else env.get(var, "1")
    return env


class Sandbox:
    """One child process running one task at a time (see the module docstring)."""

    def __init__(self, env: dict):
        self.env = env
        self.proc = None
        self.conn = None
        self.task = None  # the task the child is running, None when idle
        self.sent_at = 0.0

    def start(self) -> None:
        mine, theirs = socket.socketpair()
        code = f"from refsim.run.sandbox import serve; serve({theirs.fileno()})"
        self.proc = subprocess.Popen([sys.executable, "-c", code], env=self.env,
                                     pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL)
        theirs.close()
        self.conn = Connection(mine.detach())

    def send(self, task, registrations=()) -> None:
        if self.proc is None:
            self.start()
        self.task, self.sent_at = task, time.monotonic()
        try:
            self.conn.send((task, registrations))
        except OSError:  # the child died between two jobs: the receive side will say how
            pass

    def overdue(self, timeout) -> bool:
        return timeout is not None and time.monotonic() - self.sent_at > timeout

    def receive(self) -> dict:
        """The row of the task sent (call when `conn` is readable): the child's row, or a
        `failed` row naming how it died (the child is then replaced on the next send)."""
        task, wall = self.task, time.monotonic() - self.sent_at
        self.task = None
        try:
            kind, payload = self.conn.recv()
        except (EOFError, OSError):
            code = self.proc.wait()
            self._forget()
            return lost_row(task, "failed", death_reason(code), wall, socket.gethostname())
        if kind == "error":
            return lost_row(task, "failed", payload, wall, socket.gethostname())
        return payload[1]

    def time_out(self, timeout: float) -> dict:
        """Kill the child running past `timeout`: a `timeout` row; a fresh child follows."""
        task, wall = self.task, time.monotonic() - self.sent_at
        self.task = None
        self.close(kill=True)
        return lost_row(task, "timeout", f"no result within --timeout {timeout:g} s "
                        "(worker killed and replaced)", wall, socket.gethostname())

    def run(self, task, registrations=(), timeout=None) -> dict:
        """One task, synchronously (the Dask worker's way)."""
        self.send(task, registrations)
        if self.conn.poll(timeout):
            return self.receive()
        return self.time_out(timeout)

    def close(self, kill: bool = False) -> None:
        if self.proc is None:
            return
        if kill:
            self.proc.kill()
        self.conn.close()  # an idle child reads EOF and exits
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self._forget()

    def _forget(self):
        if self.conn is not None and not self.conn.closed:
            self.conn.close()
        self.proc, self.conn = None, None


def serve(fd: int) -> None:
    """The child's loop: receive a task, run it, send ("row", (job, row)); exit on EOF."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    from refsim import registry
    conn = Connection(fd)
    while True:
        try:
            task, registrations = conn.recv()
        except (EOFError, OSError):
            return
        for kind, name, target in registrations:
            registry.register(kind, name, target)
        try:
            reply = ("row", run_task(task))
        except Exception as exc:  # outside run_job's own capture (an unknown engine name)
            reply = ("error", f"{type(exc).__name__}: {exc}".splitlines()[0])
        try:
            conn.send(reply)
        except OSError:  # the parent is gone
            return


_LOCAL = threading.local()
_DASK_BOXES: list[Sandbox] = []  # every worker thread's Sandbox in this process
_DASK_LOCK = threading.Lock()


def dask_task(task, registrations=(), timeout=None) -> tuple:
    """What a Dask worker runs: the task in this worker thread's Sandbox (kept between tasks,
    replaced after a crash or a timeout). Returns (job, row)."""
    box = getattr(_LOCAL, "box", None)
    if box is None:
        box = _LOCAL.box = Sandbox(child_env(pin_threads=True))
        with _DASK_LOCK:
            _DASK_BOXES.append(box)
    return task[0], box.run(task, registrations, timeout)


def close_dask_boxes() -> None:
    """Stop the Sandbox children of the Dask worker threads in this process (a local cluster's
    workers are threads here: their children must not outlive the run)."""
    with _DASK_LOCK:
        boxes = list(_DASK_BOXES)
        _DASK_BOXES.clear()
    for box in boxes:
        box.close(kill=box.task is not None)
