"""Where the jobs of a run execute. Each executor's `results(tasks, size)` yields (job, row)
as jobs finish; `refsim.run.runner.run_matrix` stores each row as it arrives.

- `InProcess`: one after the other in this process (the library default for one worker; no
  isolation: what tests and notebooks call).
- `Local(workers, timeout)`: `workers` child processes on this machine, each one job at a time
  in a `refsim.run.sandbox.Sandbox`: a job whose engine kills its process is a `failed` row naming
  the signal, one past `timeout` seconds a `timeout` row, and a fresh process takes the next.
- `Dask(scheduler | workers, timeout)`: the jobs on a Dask cluster, an existing one at
  `scheduler` or a local one of `workers` single-thread workers in this process; every Dask
  worker thread runs its jobs in a Sandbox process of its own (BLAS/OpenMP on one thread), so
  crashes and timeouts give the same rows as locally. A worker lost for any other reason gives a `failed` row
  ("worker died: KilledWorker").

Task: (job, run_id, repeats, budget_s). The largest jobs (by `size`, the case's work
estimate) start first, so that none is left running alone at the end.
"""
from __future__ import annotations

import importlib.util
import time
from collections import deque
from multiprocessing.connection import wait

from refsim.run.sandbox import (Sandbox, child_env, close_dask_boxes, dask_task, lost_row,
                            run_task, runtime_registrations)


class InProcess:
    workers = 1

    def describe(self) -> dict:
        return {"executor": "in-process", "workers": 1}

    def results(self, tasks, size=None):
        yield from map(run_task, tasks)


class Local:
    def __init__(self, workers: int = 1, timeout: float | None = None):
        self.workers, self.timeout = int(workers), timeout

    def describe(self) -> dict:
        return {"executor": "local", "workers": self.workers, "timeout_s": self.timeout}

    def results(self, tasks, size=None):
        pending = deque(sorted(tasks, key=lambda t: -size(t[0])) if size else tasks)
        env = child_env(pin_threads=self.workers > 1)
        boxes = [Sandbox(env) for _ in range(max(1, min(self.workers, len(pending))))]
        registrations = runtime_registrations()
        try:
            while pending or any(b.task is not None for b in boxes):
                for box in boxes:
                    if box.task is None and pending:
                        box.send(pending.popleft(), registrations)
                busy = [b for b in boxes if b.task is not None]
                ready = wait([b.conn for b in busy], timeout=self._wait_s(busy))
                for box in busy:
                    if box.conn in ready:
                        task = box.task
                        yield task[0], box.receive()
                    elif box.overdue(self.timeout):
                        task = box.task
                        yield task[0], box.time_out(self.timeout)
        finally:
            for box in boxes:
                box.close(kill=box.task is not None)

    def _wait_s(self, busy):
        if self.timeout is None:
            return None
        now = time.monotonic()
        return max(0.0, min(b.sent_at + self.timeout - now for b in busy)) + 0.01


class Dask:
    def __init__(self, scheduler: str | None = None, workers: int | None = None,
                 timeout: float | None = None):
        if (scheduler is None) == (workers is None):
            raise ValueError("Dask needs a scheduler address or a number of local workers")
        if importlib.util.find_spec("distributed") is None:
            raise ValueError("--scheduler and --dask-workers must have Dask installed: "
                             "pip install 'refsim[dask]'")
        self.scheduler, self.timeout = scheduler, timeout
        self.workers = workers or 0

    def describe(self) -> dict:
        return {"executor": "dask", "scheduler": self.scheduler or "local cluster",
                "workers": self.workers, "timeout_s": self.timeout}

    def _client(self):
        from distributed import Client, LocalCluster
        if self.scheduler:
            return Client(self.scheduler), None
        # Worker threads in this process: each job already runs in a Sandbox process of its
        # own (crash and timeout isolation), so worker processes and nannies would only add
        # their start-up and monitoring CPU to the run (measured: +9 s of CPU on a 40 s run).
        cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=False,
                               dashboard_address=None)
        return Client(cluster), cluster

    def results(self, tasks, size=None):
        from distributed import as_completed
        client, cluster = self._client()
        try:
            self.workers = len(client.nthreads()) or self.workers
            ranked = sorted(tasks, key=lambda t: -size(t[0])) if size else list(tasks)
            registrations = runtime_registrations()
            futures = {client.submit(dask_task, task, registrations, self.timeout,
                                     pure=False, priority=len(ranked) - k): task
                       for k, task in enumerate(ranked)}
            for future in as_completed(futures):
                yield self._row(future, futures[future])
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
                close_dask_boxes()

    @staticmethod
    def _row(future, task):
        try:
            return future.result()
        except Exception as exc:  # KilledWorker: the Dask worker itself died on this job
            reason = f"worker died: {type(exc).__name__}" if "Killed" in type(exc).__name__ \
                else f"{type(exc).__name__}: {exc}".splitlines()[0]
            return task[0], lost_row(task, "failed", reason, 0.0)
