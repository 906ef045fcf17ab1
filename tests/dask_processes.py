"""A Dask cluster of separate processes, as a user starts one: ``dask scheduler`` and ``dask
worker`` (the venv's ``dask`` command line) in a folder of their own, each in its own process
group, so that :meth:`DaskProcesses.kill_worker` takes a worker's nanny and worker process down
together (a lost machine) and :meth:`DaskProcesses.close` leaves no process behind.

The scheduler listens on a port the OS picks (``--port 0``) and says which in its scheduler
file. Every process reads ``dask.yaml`` of the folder (``DASK_CONFIG``), which removes Dask's
default ``MALLOC_TRIM_THRESHOLD_`` from the workers' environment (docs/guide/scale.md). Used by
tests/test_study_cluster.py and benchmarks/bench_dask_cluster.py.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

#: the venv's ``dask`` command (beside its python)
DASK = str(Path(sys.executable).with_name("dask"))

#: the Dask configuration of docs/guide/scale.md
DASK_YAML = """\
distributed:
  nanny:
    pre-spawn-environ:
      MALLOC_TRIM_THRESHOLD_: null
"""


class DaskProcesses:
    """``dask scheduler`` and named ``dask worker`` processes started in ``folder`` (see the
    module docstring); ``env``: extra environment variables of every process."""

    def __init__(self, folder: Path, env: dict[str, str] | None = None):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        (self.folder / "dask.yaml").write_text(DASK_YAML)
        self.env = {**os.environ, "DASK_CONFIG": str(self.folder), **(env or {})}
        self.scheduler_file = self.folder / "scheduler.json"
        self.procs: dict[str, subprocess.Popen] = {}
        self.address: str | None = None
        self._client = None

    def _start(self, name: str, args: list[str], env: dict[str, str] | None) -> None:
        log = open(self.folder / f"{name}.log", "wb")  # noqa: SIM115 - closed with the process
        self.procs[name] = subprocess.Popen(
            [DASK, *args], cwd=self.folder, env={**self.env, **(env or {})}, stdout=log,
            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True)
        log.close()

    def log(self, name: str) -> str:
        return (self.folder / f"{name}.log").read_text(errors="replace")

    def start_scheduler(self, timeout: float = 60.0) -> str:
        """Start ``dask scheduler`` and return its address once its scheduler file names it."""
        self._start("scheduler", ["scheduler", "--host", "127.0.0.1", "--port", "0",
                                  "--no-dashboard", "--scheduler-file",
                                  str(self.scheduler_file)], None)
        deadline = time.monotonic() + timeout
        while True:
            try:
                self.address = json.loads(self.scheduler_file.read_text())["address"]
                return self.address
            except (OSError, ValueError, KeyError):
                pass
            if self.procs["scheduler"].poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"dask scheduler did not start:\n{self.log('scheduler')}")
            time.sleep(0.1)

    def start_worker(self, name: str, env: dict[str, str] | None = None) -> None:
        """Start ``dask worker`` (one single-threaded worker process under its nanny) named
        ``name``; ``env``: its own extra environment variables."""
        self._start(name, ["worker", "--scheduler-file", str(self.scheduler_file), "--name",
                           name, "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                           "--local-directory", str(self.folder / f"{name}-space")], env)

    def client(self):
        """A Dask client of this cluster (closed with it)."""
        if self._client is None:
            from distributed import Client

            self._client = Client(self.address, timeout="30s")
        return self._client

    def wait_for_workers(self, n: int, timeout: float = 120.0) -> dict[str, str]:
        """Wait until ``n`` workers are connected; returns worker name -> address."""
        self.client().wait_for_workers(n, timeout=timeout)
        return self.worker_addresses()

    def worker_addresses(self) -> dict[str, str]:
        workers = self.client().scheduler_info(n_workers=-1)["workers"]
        return {str(w["name"]): addr for addr, w in workers.items()}

    def kill_worker(self, name: str) -> None:
        """SIGKILL the process group of worker ``name``: its nanny and its worker process."""
        proc = self.procs[name]
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)

    def close(self) -> None:
        """Close the client, then end every process group (SIGTERM, SIGKILL after 10 s)."""
        if self._client is not None:
            self._client.close()
            self._client = None
        for proc in self.procs.values():
            if proc.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGTERM)
        deadline = time.monotonic() + 10
        for proc in self.procs.values():
            try:
                proc.wait(timeout=max(deadline - time.monotonic(), 0.1))
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=10)
        # the group may outlive its leader (a worker process whose nanny is gone)
        for proc in self.procs.values():
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)

    def __enter__(self) -> DaskProcesses:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

