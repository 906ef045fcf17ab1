"""The study's independent stages on the machine's second core: a one-process pool beside it.

``torchrom paper`` runs in one process whose numerical work is single-threaded where it
matters (torch's batched LU, the shooting certificate), so on a 2-core machine half the
machine would idle. The stages that do not need the main sweeps — the other wing variant
(its own model: submitted before the study's model stage), then, once the model exists, the
damping criterion's semidefinite program (its member's sweep runs in the study's process, at
the band: with it, the second process was the longer one), the LCO branches and the
stiffness-cause orbits — are submitted to a second process (spawned, not forked: the study's
process may already have run torch's OpenMP thread pool, which a fork does not carry over
safely), run there in that order, and are collected at their own stage, in the report's
order. From the first job on, each process keeps to one torch thread and one BLAS thread
(NumPy's and SciPy's OpenBLAS, :func:`one_blas_thread`). A job whose files are all cached
runs in place at once (:func:`~.cache.probing`), so a cached rerun starts no worker.

A job is a top-level function ``fn(cache, *args, log=..., **kwargs)`` of the study, called
with a :class:`~.cache.DeferredCache` on the study's folder: it reads the study's cache and
writes its own files, and the study's process records them in the manifest when it collects
the job (one writer of ``cache.json``). Its ``log`` lines are replayed then, under the stage's
heading. Without a second core, or with :data:`ENV` = 1, :meth:`Beside.submit` defers the call
to :meth:`Job.result`, which runs it in the study's own process with the study's cache — the
order and the results of the single-process study.

Written here: a thin layer over :mod:`concurrent.futures`.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from ..errors import InputError
from .cache import CacheMiss, DeferredCache, FileCache, probing

#: processes of the study (1: everything in the command's own; 2: a second one beside it);
#: by default 2 where the machine has at least two cores
ENV = "TORCHROM_PAPER_PROCESSES"


def study_processes() -> int:
    """How many processes the study uses (:data:`ENV`, else 2 with two cores or more)."""
    raw = os.environ.get(ENV)
    if raw is None:
        from ..limits import usable_cpus

        return 2 if usable_cpus() >= 2 else 1
    if raw.strip() not in ("1", "2"):
        raise InputError(f"environment variable {ENV}: expected 1 or 2, got {raw!r}")
    return int(raw)


#: the BLAS of NumPy and SciPy (OpenBLAS) reads this when it loads: the worker starts with it
#: set to 1 (:class:`Beside`)
BLAS_ENV = "OPENBLAS_NUM_THREADS"


def one_blas_thread():
    """Limit the BLAS libraries loaded in this process (NumPy's, SciPy's, SCS's) to one thread
    (threadpoolctl; a handle whose ``restore_original_limits()`` undoes it). With two processes
    on two cores, a BLAS call on two threads waits for a core the other process holds: on a
    loaded 2-core machine the model stage's rational-function fit took 57 s instead of 1.5 s
    and the flutter solution 1.2 s instead of 0.35 s."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def _start_worker() -> None:
    """A worker's settings: one intra-op thread and one BLAS thread (the study's process has
    the other core) and no progress output (its bars would interleave with the study's; its
    log lines come back with the result)."""
    import torch

    from ..progress import QUIET, set_verbosity

    torch.set_num_threads(1)
    one_blas_thread()  # the libraries loaded before the environment could act (numpy)
    set_verbosity(QUIET)


def _run_job(fn: Callable, folder: str, force: bool, args: tuple, kwargs: dict
             ) -> tuple[Any, dict, list[str], list[str]]:
    """In the worker: ``fn`` with a deferred cache; (value, files written, files reused, log
    lines)."""
    lines: list[str] = []
    cache = DeferredCache(folder, force=force)
    value = fn(cache, *args, log=lines.append, **kwargs)
    return value, cache.written(), list(cache.hits), lines


def _run_probe(fn: Callable, folder: str, force: bool, args: tuple, kwargs: dict
               ) -> tuple[Any, dict, list[str], list[str]]:
    """:func:`_run_job` in this process, raising :class:`~.cache.CacheMiss` at the first file
    it would build."""
    with probing():
        return _run_job(fn, folder, force, args, kwargs)


@dataclass
class Job:
    """A submitted stage: its future (or, without a worker, the call itself)."""

    fn: Callable
    args: tuple
    kwargs: dict
    future: Future | None = None
    #: a job found cached whole when it was submitted: (value, files, reused, log lines)
    cached: tuple | None = field(default=None, repr=False)
    done: bool = False
    value: Any = field(default=None, repr=False)

    def result(self, cache: FileCache, log: Callable[[str], None]) -> Any:
        """The stage's value: the worker's (its files recorded in ``cache``, its lines written
        to ``log``), or the call made now in this process."""
        if self.done:
            return self.value
        if self.future is None and self.cached is None:
            self.value = self.fn(cache, *self.args, log=log, **self.kwargs)
        else:
            if self.future is not None and not self.future.done():
                log("  computed in the second process: waiting for it to finish")
            value, written, hits, lines = (self.cached if self.cached is not None
                                           else self.future.result())
            cache.adopt(written, hits)
            for line in lines:
                log(line)
            self.value = value
        self.done = True
        return self.value


class Beside:
    """The pool of one worker process (module docstring); a context manager that stops it
    (also on an error or an interruption, cancelling what it had not started)."""

    def __init__(self, folder: Path, force: bool, processes: int):
        self.folder, self.force, self.processes = str(folder), force, processes
        self.pool = (ProcessPoolExecutor(1, mp_context=get_context("spawn"),
                                         initializer=_start_worker) if processes > 1 else None)
        self._threads = None
        self._blas = None
        self._blas_env = os.environ.get(BLAS_ENV)

    def __enter__(self) -> Beside:
        return self

    def submit(self, fn: Callable, *args, **kwargs) -> Job:
        """``fn(cache, *args, log=..., **kwargs)`` in the worker (module docstring); the worker
        starts with the first job, and from then on this process keeps to one thread. A job
        whose files are all cached is run here at once (:func:`~.cache.probing`: reading them
        costs less than starting a worker)."""
        job = Job(fn, args, kwargs)
        if self.pool is not None:
            try:
                job.cached = _run_probe(fn, self.folder, self.force, args, kwargs)
                return job
            except CacheMiss:
                pass
            if self._threads is None:
                import torch

                # the worker has the other core: torch's (and the BLAS's) two threads here
                # would share it; the worker, spawned now, loads its BLAS with one thread
                self._threads = torch.get_num_threads()
                torch.set_num_threads(1)
                self._blas = one_blas_thread()
                os.environ[BLAS_ENV] = "1"
            job.future = self.pool.submit(_run_job, fn, self.folder, self.force, args, kwargs)
        return job

    def __exit__(self, exc_type, exc, tb) -> None:
        if self.pool is None:
            return
        if exc_type is None:
            self.pool.shutdown(wait=True)
        else:
            # an error or an interruption: nothing more to compute; the worker is stopped
            procs = list(getattr(self.pool, "_processes", {}).values())
            self.pool.shutdown(wait=False, cancel_futures=True)
            for p in procs:
                p.terminate()
        if self._threads is not None:
            import torch

            torch.set_num_threads(self._threads)
            self._blas.restore_original_limits()
            if self._blas_env is None:
                os.environ.pop(BLAS_ENV, None)
            else:
                os.environ[BLAS_ENV] = self._blas_env


__all__ = ["Beside", "Job", "ENV", "study_processes", "one_blas_thread"]
