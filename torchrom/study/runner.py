"""Chunked, resumable and optionally distributed execution of sweep cases.

Orchestration; Dask ``distributed`` does the scale-out (LocalCluster, Client,
futures, as_completed), pandas/pyarrow write the part files, hashlib the checksums.

**Tasks and chunks.** A *task* is a picklable callable ``task(cases, case_ids, progress=None)``
returning a :class:`ChunkResult` (one table row per case, in order). The cases of a sweep are
split into chunks (:func:`plan_chunks`); one chunk is one batched integration, the unit of work
sent to a worker and the unit of storage. The split depends only on the number of cases and on
``batch_size`` / ``chunk_size`` — never on the number of workers — so an in-process run, a cluster
run and a resumed run integrate the same batches and give bit-identical numbers. By default
a sweep gets about :data:`TARGET_CHUNKS` chunks of at least :data:`MIN_CHUNK` cases and at most
``batch_size``: the batched integrator's cost per case falls steeply up to batches of ~64 and
slowly after that (``benchmarks/bench_integrator.py``), while several chunks keep a few workers
busy and keep the work lost to an interrupt small. Large clusters want more chunks: set
``[run] chunk_size`` or ``--chunk-size``.

**Executors** (:func:`open_executor`). In-process by default (a plain loop, Dask is not even
imported; progress is reported within a chunk); ``workers=N`` starts a LocalCluster of N
single-threaded worker processes (torch intra-op threads = 1 in each: on a CPU one process per
core beats one process with threads; without Dask's default ``MALLOC_TRIM_THRESHOLD_``, which
made a chunk run slower in a worker than in-process); ``scheduler=ADDR`` uses an existing
cluster, whose workers must run this client's torchrom, torch, dask and Python (refused
otherwise, on connect and again by every chunk: :mod:`torchrom.study.cluster`). The task is
submitted once as a computed future (not scattered data), so a worker that dies is replaced by
its nanny and everything it held — the task and the chunk it was integrating — is recomputed
elsewhere by the scheduler; a finished chunk's future is released as soon as its rows have been
stored, so finished work is never redone.

**Part files** (:class:`PartStore`). With an output folder, each finished chunk is written at
once as ``parts/part-<hash>.parquet`` (atomically: temporary file, then rename), followed by
its sidecar ``part-<hash>.json`` with the SHA-256, size, run key and case ids;
``parts/manifest.json`` records the run key (a hash of the configuration, the model and the
precision). A rerun with the same run key reads the valid parts and computes only the missing
cases. A part whose checksum, size, run key or case ids do not match (truncated, corrupted,
or left by a crash between the two renames) is moved to ``parts/rejected/`` with a warning and
its cases are recomputed. Parts of another run key in the same folder are refused unless
``force`` (then those parts, and only those, are deleted: parts whose sidecar names this run key
are kept and reused, also when ``manifest.json`` itself is unreadable). The final table is
always assembled from the part files, in case order, so an interrupted-and-resumed sweep gives
exactly the table of an uninterrupted one. ``parts/outputs.json`` records the SHA-256 of the
outputs written from the parts (:meth:`PartStore.record_outputs`), so that a rerun can tell an
output it wrote from one edited since.

**No lost work.** The folder is locked for the run (:mod:`torchrom.locks`). A Ctrl-C that
arrives once a chunk's cases are integrated takes effect after its part is stored
(:mod:`torchrom.interrupts`); a chunk that fails on a cluster does not cancel the others (every
chunk that finishes is stored, then the failure is raised); an interrupted or failed run logs
how many cases its parts keep.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import io
import json
import math
import shutil
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import pandas as pd

from .._version import __version__
from ..errors import InputError, TorchromError
from ..io import atomic_path, write_json_atomic

#: default number of chunks a sweep is split into (when the cases allow it)
TARGET_CHUNKS = 8
#: smallest default chunk (the batched integrator is far cheaper per case at B >= 32..64)
MIN_CHUNK = 32
PART_FORMAT = "torchrom-parts-1"
#: tables a part may hold beside its rows -> their file name infix (``part-<hash>.hist.parquet``)
EXTRAS = {"histories": "hist", "orbits": "orbits"}

Progress = Callable[[int, int], None]


@dataclass
class ChunkResult:
    """What a task returns for one chunk: the table rows (one per case, in order) and timing."""

    rows: pd.DataFrame
    wall_time_s: float = 0.0
    case_steps: int = 0
    #: output time histories of the chunk's cases that asked for them (long format, with a
    #: ``case_id`` column), or None
    histories: pd.DataFrame | None = None
    #: harmonic balance: the chunk's LCO orbits (:func:`torchrom.study.cases.orbit_table`), or
    #: None; handed to ``on_orbits`` of :func:`run_cases`, not stored in part files
    orbits: pd.DataFrame | None = None
    #: of ``wall_time_s``, the seconds the LCO rows' certificate took
    certificate_s: float = 0.0


class Task(Protocol):
    def __call__(self, cases: list[dict[str, Any]], case_ids: list[str],
                 progress: Progress | None = None) -> ChunkResult: ...


# ----------------------------------------------------------------------------------------------
# chunking
# ----------------------------------------------------------------------------------------------
def plan_chunks(n_cases: int, batch_size: int, chunk_size: int | None = None) -> list[range]:
    """Split case indices 0..n_cases-1 into contiguous chunks of nearly equal size.

    ``chunk_size`` given: chunks of that many cases (the last one shorter). Otherwise
    max(ceil(n / batch_size), min(TARGET_CHUNKS, ceil(n / MIN_CHUNK))) chunks whose sizes
    differ by at most one (see the module docstring)."""
    if n_cases <= 0:
        return []
    if chunk_size is not None:
        if chunk_size < 1:
            raise InputError(f"chunk_size: expected a positive integer, got {chunk_size}")
        return [range(a, min(a + chunk_size, n_cases)) for a in range(0, n_cases, chunk_size)]
    count = max(math.ceil(n_cases / batch_size),
                min(TARGET_CHUNKS, math.ceil(n_cases / MIN_CHUNK)))
    base, extra = divmod(n_cases, count)
    chunks, start = [], 0
    for k in range(count):
        size = base + (1 if k < extra else 0)
        chunks.append(range(start, start + size))
        start += size
    return chunks


def chunk_key(case_ids: Sequence[str]) -> str:
    """Name of a chunk's part file: a hash of its case ids (16 hex digits)."""
    return hashlib.sha256("\n".join(case_ids).encode()).hexdigest()[:16]


# ----------------------------------------------------------------------------------------------
# part files
# ----------------------------------------------------------------------------------------------
def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@dataclass
class PartStore:
    """The part files of one sweep in ``folder/parts`` (see the module docstring).

    ``run`` describes the run: ``run_key`` (required; what case ids and stored results depend
    on) plus descriptive entries (config_hash, model_hash, dtype, title, config) that name
    what changed when a folder is reused with another run key.
    """

    folder: Path
    run: dict[str, str]
    warn: Callable[[str], None] = print
    _opened: bool = field(default=False, init=False, repr=False)
    #: kind (:data:`EXTRAS`) -> sidecar name -> table, of the valid parts found by load()
    _extras: dict[str, dict[str, pd.DataFrame]] = field(default_factory=dict, init=False,
                                                        repr=False)

    @property
    def parts(self) -> Path:
        return Path(self.folder) / "parts"

    @property
    def manifest_path(self) -> Path:
        return self.parts / "manifest.json"

    @property
    def run_key(self) -> str:
        return self.run["run_key"]

    def previous_run(self) -> dict[str, Any] | None:
        """The manifest of the results already in the folder (None when there are none)."""
        if not self.manifest_path.exists():
            return None
        try:
            old = json.loads(self.manifest_path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            old = None
        return old if isinstance(old, dict) else {"run_key": "unreadable manifest"}

    def _part_keys(self) -> dict[Path, str | None]:
        """Sidecar -> the run key it records (None: unreadable) for every part in the folder."""
        keys: dict[Path, str | None] = {}
        for sidecar in sorted(self.parts.glob("part-*.json")):
            try:
                keys[sidecar] = json.loads(sidecar.read_text()).get("run_key")
            except (json.JSONDecodeError, UnicodeDecodeError, OSError, AttributeError):
                keys[sidecar] = None
        return keys

    def check(self, force: bool = False) -> bool:
        """True when the folder holds results of this very run (resumable: the manifest, or
        when it is unreadable the parts' own sidecars, name this run key), False when it holds
        none, or only another run's with ``force``; InputError naming what changed when it
        holds parts it cannot prove to be this run's and ``force`` is not set."""
        old = self.previous_run()
        keys = self._part_keys()
        own = any(k == self.run_key for k in keys.values())
        if old is None:
            return own
        if old.get("run_key") == self.run_key:
            return True
        extra = tuple(f".{ext}.parquet" for ext in EXTRAS.values())
        sidecar_parts = {s.with_suffix(".parquet") for s in keys}
        unproven = [s for s, k in keys.items() if k != self.run_key] + [
            p for p in self.parts.glob("part-*.parquet")
            if p not in sidecar_parts and not p.name.endswith(extra)]
        if unproven and not force:
            what = (f"its {self.manifest_path.name} is unreadable and {len(unproven)} parts are"
                    f" not this run's" if old.get("run_key") == "unreadable manifest" else
                    f"{self._changed(old)}: run key {old.get('run_key')} -> {self.run_key}")
            raise InputError(
                f"{self.folder}: holds sweep results of a different configuration ({what}); "
                f"pass --force to discard them (parts of this run are kept) or choose another "
                f"output folder")
        return own

    def _changed(self, old: dict[str, Any]) -> str:
        changed = [k for k in ("model_hash", "config_hash", "dtype")
                   if k in old and old.get(k) != self.run.get(k)]
        return (", ".join(k.replace("_hash", "") for k in changed) or "run key") + " changed"

    def open(self, force: bool = False) -> None:
        """Check the folder (:meth:`check`), then write the manifest; with ``force``, the part
        files of another run are deleted first — only those: parts whose sidecar names this
        run key are kept and reused (:meth:`load` still checks each of them)."""
        old = self.previous_run()
        self.check(force)
        foreign = [s for s, k in self._part_keys().items() if k is not None and k != self.run_key]
        for sidecar in foreign:
            for p in self._files_of(sidecar):
                p.unlink(missing_ok=True)
        if foreign:
            self.warn(f"--force: removed {len(foreign)} parts of a previous configuration "
                      f"({self._changed(old or {})}) from {self.parts}")
        self.parts.mkdir(parents=True, exist_ok=True)
        write_json_atomic(self.manifest_path, {"format": PART_FORMAT, **self.run,
                                               "version": __version__})
        self._opened = True

    @property
    def outputs_path(self) -> Path:
        return self.parts / "outputs.json"

    def record_outputs(self, paths: Sequence[Path]) -> None:
        """Record the SHA-256 of the outputs written from the parts (results table, figures):
        :meth:`edited_outputs` tells a file changed since from one this run may replace."""
        files = {Path(p).name: _sha256(Path(p).read_bytes()) for p in paths if Path(p).is_file()}
        write_json_atomic(self.outputs_path, {"format": PART_FORMAT, "run_key": self.run_key,
                                              "files": files})

    def edited_outputs(self, paths: Sequence[Path]) -> list[str]:
        """One line for each existing file of ``paths`` that this run did not write as it is
        now (hash differs from :meth:`record_outputs`' record, or no record of it)."""
        try:
            record = json.loads(self.outputs_path.read_text())
            files = record.get("files", {}) if record.get("run_key") == self.run_key else {}
        except (OSError, json.JSONDecodeError, UnicodeDecodeError, AttributeError):
            files = {}
        lines = []
        for p in map(Path, paths):
            if not p.is_file():
                continue
            if p.name not in files:
                lines.append(f"{p}: not written by this sweep (no record of it in "
                             f"{self.outputs_path})")
            elif _sha256(p.read_bytes()) != files[p.name]:
                lines.append(f"{p}: changed since this sweep wrote it (its SHA-256 differs "
                             f"from the one in {self.outputs_path})")
        return lines

    @staticmethod
    def _files_of(sidecar: Path) -> list[Path]:
        """A part's files: its extra tables (:data:`EXTRAS`), the rows, then the sidecar."""
        stem = sidecar.with_suffix("")
        return [*(stem.with_suffix(f".{ext}.parquet") for ext in EXTRAS.values()),
                sidecar.with_suffix(".parquet"), sidecar]

    def write(self, rows: pd.DataFrame, histories: pd.DataFrame | None = None,
              orbits: pd.DataFrame | None = None) -> Path:
        """Store one finished chunk (rows with a ``case_id`` column) and, when given, its time
        histories and orbits: parquet files first, then the sidecar with their checksums."""
        if not self._opened:
            raise RuntimeError("PartStore.write before open()")
        ids = [str(c) for c in rows["case_id"]]
        name = f"part-{chunk_key(ids)}"
        meta = {"format": PART_FORMAT, "run_key": self.run_key}
        for kind, frame in (("", rows), ("histories", histories), ("orbits", orbits)):
            if frame is None:
                continue
            buf = io.BytesIO()
            frame.to_parquet(buf, index=False)
            data = buf.getvalue()
            with atomic_path(self._path(name, kind)) as tmp:
                tmp.write_bytes(data)
            prefix = f"{kind}_" if kind else ""
            meta.update({f"{prefix}sha256": _sha256(data), f"{prefix}bytes": len(data)})
        write_json_atomic(self.parts / f"{name}.json", {**meta, "rows": len(ids), "case_ids": ids})
        return self.parts / f"{name}.parquet"

    def _path(self, name: str, kind: str = "") -> Path:
        return self.parts / (f"{name}.{EXTRAS[kind]}.parquet" if kind else f"{name}.parquet")

    @staticmethod
    def _read_checked(path: Path, meta: dict, kind: str = "") -> tuple[pd.DataFrame | None, str]:
        prefix = f"{kind}_" if kind else ""
        if not path.exists():
            return None, f"{path.name} missing"
        data = path.read_bytes()
        if len(data) != meta.get(f"{prefix}bytes") or _sha256(data) != meta.get(f"{prefix}sha256"):
            return None, (f"checksum mismatch of {path.name} ({len(data)} bytes, expected "
                          f"{meta.get(f'{prefix}bytes')}): truncated or corrupted")
        try:
            return pd.read_parquet(io.BytesIO(data)), ""
        except Exception as exc:  # noqa: BLE001 - any reader failure means a bad part
            return None, f"unreadable parquet {path.name} ({type(exc).__name__})"

    def _check(self, sidecar: Path) -> tuple[pd.DataFrame | None, str]:
        """(rows, "") for a valid part, (None, reason) otherwise."""
        try:
            meta = json.loads(sidecar.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError, OSError):
            return None, "unreadable sidecar"
        if not isinstance(meta, dict):
            return None, "unreadable sidecar"
        if not sidecar.with_suffix(".parquet").exists():
            return None, "part file missing"
        if meta.get("run_key") != self.run_key:
            return None, f"written for run key {meta.get('run_key')}"
        rows, reason = self._read_checked(sidecar.with_suffix(".parquet"), meta)
        if rows is None:
            return None, reason
        if "case_id" not in rows or [str(c) for c in rows["case_id"]] != meta.get("case_ids"):
            return None, "case ids do not match its sidecar"
        for kind in EXTRAS:
            if f"{kind}_sha256" in meta:
                extra, reason = self._read_checked(self._path(sidecar.stem, kind), meta, kind)
                if extra is None:
                    return None, reason
                self._extras[kind][sidecar.name] = extra
        return rows, ""

    def _reject(self, path: Path, reason: str) -> None:
        dest = self.parts / "rejected"
        dest.mkdir(exist_ok=True)
        stamp = time.strftime("%Y%m%dT%H%M%S")
        for p in self._files_of(path.with_suffix(".json")):
            if p.exists():
                shutil.move(str(p), dest / f"{p.name}.{stamp}")
        self.warn(f"warning: {path.with_suffix('.parquet')}: {reason}; moved to {dest}, its "
                  f"cases will be recomputed")

    def load(self) -> pd.DataFrame | None:
        """The rows of every valid part (None when there are none); bad parts are rejected."""
        if not self.parts.is_dir():
            return None
        frames = []
        self._extras = {kind: {} for kind in EXTRAS}
        sidecars = sorted(self.parts.glob("part-*.json"))
        for sidecar in sidecars:
            rows, reason = self._check(sidecar)
            if rows is None:
                self._reject(sidecar, reason)
            else:
                frames.append(rows)
        covered = {s.with_suffix(".parquet") for s in sidecars}
        extra = tuple(f".{ext}.parquet" for ext in EXTRAS.values())
        for orphan in sorted(self.parts.glob("part-*.parquet")):
            if orphan not in covered and not orphan.name.endswith(extra):
                self._reject(orphan, "no sidecar (interrupted while being written)")
        if not frames:
            return None
        return pd.concat(frames, ignore_index=True)

    def load_extra(self, kind: str) -> pd.DataFrame | None:
        """The ``kind`` tables (:data:`EXTRAS`: histories, orbits) stored with the valid parts
        found by the last :meth:`load`."""
        frames = list(self._extras.get(kind, {}).values())
        return pd.concat(frames, ignore_index=True) if frames else None


# ----------------------------------------------------------------------------------------------
# executors
# ----------------------------------------------------------------------------------------------
def _identity(x):
    return x


def _run_chunk_on_worker(task: Task, cases, case_ids,
                         identity: dict[str, str] | None = None) -> ChunkResult:
    """Dask entry point: one intra-op torch thread per concurrently running chunk; with
    ``identity`` (the client's code, :mod:`torchrom.study.cluster`), a worker running other
    code refuses the chunk."""
    import torch

    if identity is not None:
        from .cluster import check_this_worker

        check_this_worker(identity)
    if torch.get_num_threads() != 1:
        torch.set_num_threads(1)
    return task(cases, case_ids)


class InProcessExecutor:
    """Run chunks one after another in this process (progress within each chunk)."""

    description = "in-process"

    def run(self, task: Task, chunks: list[tuple[list[dict], list[str]]],
            progress: Progress | None = None, finishing: Callable[[], None] | None = None
            ) -> Iterator[tuple[int, ChunkResult]]:
        """Yield (k, result) chunk by chunk; ``finishing()`` is called when a chunk's last case
        is done (before its rows are built) and again when the task returns."""
        done, total = 0, sum(len(c) for c, _ in chunks)
        finishing = finishing or (lambda: None)
        for k, (cases, ids) in enumerate(chunks):
            def inner(i, n, base=done):
                if i >= n:
                    finishing()
                if progress is not None:
                    progress(base + i, total)

            result = task(cases, ids, inner)
            finishing()
            yield k, result
            done += len(cases)


class DaskExecutor:
    """Run chunks as futures on a Dask cluster and yield them as they complete."""

    def __init__(self, client, description: str, identity: dict[str, str] | None = None):
        self.client = client
        self.description = description
        #: the client's code (:func:`torchrom.study.cluster.code_identity`) that every chunk
        #: checks on its worker; None: not checked (a LocalCluster runs this installation)
        self.identity = identity

    def run(self, task: Task, chunks: list[tuple[list[dict], list[str]]],
            progress: Progress | None = None, finishing: Callable[[], None] | None = None
            ) -> Iterator[tuple[int, ChunkResult]]:
        """Yield (k, result) as chunks complete; ``finishing()`` is called before a finished
        chunk's result is fetched. A failed chunk does not stop the others: every chunk that
        finishes is still yielded (and stored), then the first failure is raised."""
        from distributed import as_completed

        client = self.client
        finishing = finishing or (lambda: None)
        # a computed future (not scattered data): if the worker holding it dies, the scheduler
        # recomputes it from its recipe instead of losing it
        task_future = client.submit(_identity, task, pure=False)
        futures = {client.submit(_run_chunk_on_worker, task_future, cases, ids, self.identity,
                                 pure=False, key=f"torchrom-chunk-{k}-{chunk_key(ids)}"): k
                   for k, (cases, ids) in enumerate(chunks)}
        done, total = 0, sum(len(c) for c, _ in chunks)
        failure: TorchromError | None = None
        try:
            for fut in as_completed(list(futures)):
                k = futures.pop(fut)
                try:
                    if fut.status == "finished":
                        finishing()
                    result = fut.result()
                except Exception as exc:
                    failure = failure or TorchromError(
                        f"chunk {k} ({len(chunks[k][0])} cases) failed on the cluster: "
                        f"{type(exc).__name__}: {exc}")
                    continue
                fut.release()  # done: never recomputed if its worker dies later
                done += len(chunks[k][0])
                yield k, result
                if progress is not None:
                    progress(done, total)
        finally:
            for fut in futures:
                fut.cancel()
            task_future.cancel()
        if failure is not None:
            raise failure


@contextlib.contextmanager
def open_executor(workers: int | None = None, scheduler: str | None = None
                  ) -> Iterator[InProcessExecutor | DaskExecutor]:
    """In-process (default), a LocalCluster of ``workers`` processes, or the cluster at
    ``scheduler``; the cluster and client are closed on exit (also on Ctrl-C)."""
    if workers is not None and scheduler is not None:
        raise InputError("--workers and --scheduler: give at most one of them")
    if workers is None and scheduler is None:
        yield InProcessExecutor()
        return
    if workers is not None and workers < 1:
        raise InputError(f"--workers: expected a positive number of worker processes, got "
                         f"{workers}")
    import logging

    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise InputError(f"--scheduler: cannot connect to {scheduler!r} ({exc})") from None
        with client:
            from .cluster import check_workers

            # a worker with other code would store its rows under this run's key: refused
            identity = check_workers(client, scheduler)
            yield DaskExecutor(client, f"Dask cluster at {scheduler}", identity)
        return
    import dask

    # one single-threaded worker process per core; the nanny's pre-spawn environment sets
    # OMP/MKL_NUM_THREADS = 1, and each chunk also sets torch's intra-op threads to 1.
    # Dask's default MALLOC_TRIM_THRESHOLD_ is unset (None removes it): setting it fixes glibc's
    # mmap threshold at 128 KB, so every per-step temporary above that (the (n, n, B) per-case
    # matrices) is mmap'ed, page-faulted and unmapped again — a chunk ran 2x slower in a worker
    with _sigint_ignored_in_children(), dask.config.set(
            {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
    with cluster, Client(cluster) as client:
        yield DaskExecutor(client, f"local Dask cluster of {workers} worker process"
                                   f"{'es' if workers > 1 else ''}")


@contextlib.contextmanager
def _sigint_ignored_in_children() -> Iterator[None]:
    """Start worker processes with SIGINT ignored (an ignored signal stays ignored across exec,
    and Python then installs no KeyboardInterrupt handler): a Ctrl-C in the terminal reaches the
    whole process group, and only this process should react — by closing the cluster in order —
    instead of every worker printing a traceback."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


# ----------------------------------------------------------------------------------------------
# running
# ----------------------------------------------------------------------------------------------
@dataclass
class RunStats:
    """What a run did: cases reused from part files / computed now, and timings."""

    cases: int = 0
    reused: int = 0
    computed: int = 0
    chunks: int = 0
    wall_time_s: float = 0.0  # Σ of the chunks' integration times
    certificate_s: float = 0.0  # ... of which their certificates
    case_steps: int = 0
    elapsed_s: float = 0.0  # wall-clock time of the whole run

    def as_dict(self) -> dict[str, float]:
        return {**dataclasses.asdict(self),
                "us_per_case_step": 1e6 * self.wall_time_s / max(self.case_steps, 1)}


def _ordered(table: pd.DataFrame, case_ids: Sequence[str], warn) -> pd.DataFrame:
    """The rows of ``case_ids`` in that order, each exactly once."""
    dup = table["case_id"].duplicated(keep="first")
    if dup.any():
        warn(f"warning: {int(dup.sum())} cases were stored twice; keeping the first copy")
        table = table[~dup]
    indexed = table.set_index("case_id", drop=False)
    missing = [c for c in case_ids if c not in indexed.index]
    if missing:
        raise TorchromError(f"{len(missing)} of {len(case_ids)} cases have no result (e.g. "
                            f"{missing[0]})")
    return indexed.loc[list(case_ids)].reset_index(drop=True)


def run_cases(task: Task, cases: Sequence[dict[str, Any]], case_ids: Sequence[str], *,
              batch_size: int = 512, chunk_size: int | None = None,
              executor: InProcessExecutor | DaskExecutor | None = None,
              store: PartStore | None = None, force: bool = False,
              progress: Progress | None = None,
              log: Callable[[str], None] | None = None,
              on_history: Callable[[pd.DataFrame], None] | None = None,
              on_orbits: Callable[[pd.DataFrame], None] | None = None,
              ) -> tuple[pd.DataFrame, RunStats]:
    """Evaluate ``task`` on every case (see the module docstring); returns (table, stats).

    With ``store``, the folder is locked for the run (:func:`torchrom.locks.folder_lock`: a
    second run on it refuses), finished chunks go to part files as they complete (a Ctrl-C
    while one is being finished waits until it is stored, :mod:`torchrom.interrupts`), cases
    already stored for the same run key are skipped, and the table is assembled from the part
    files; an interrupted or failed run logs how many cases its parts keep.
    ``on_history(frame)`` / ``on_orbits(frame)`` receive the chunks' time histories
    (:attr:`ChunkResult.histories`) and harmonic balance orbits (:attr:`ChunkResult.orbits`):
    chunk by chunk without a store, all of them (stored and new) at the end with one."""
    if store is None:
        return _run_cases(task, cases, case_ids, batch_size, chunk_size, executor, None, force,
                          progress, log, on_history, on_orbits)
    from ..locks import folder_lock

    with folder_lock(store.folder, "a sweep", log=log):
        return _run_cases(task, cases, case_ids, batch_size, chunk_size, executor, store, force,
                          progress, log, on_history, on_orbits)


def _run_cases(task, cases, case_ids, batch_size, chunk_size, executor, store, force, progress,
               log, on_history, on_orbits) -> tuple[pd.DataFrame, RunStats]:
    from ..interrupts import DeferredInterrupt

    t0 = time.perf_counter()
    log = log or (lambda _msg: None)
    cases = list(cases)
    case_ids = [str(c) for c in case_ids]
    if len(set(case_ids)) != len(case_ids):
        raise InputError("cases: two cases have the same parameters (duplicate case ids)")
    executor = executor or InProcessExecutor()
    stats = RunStats(cases=len(cases))
    done_ids: set[str] = set()
    if store is not None:
        store.warn = log
        store.open(force=force)
        previous = store.load()
        if previous is not None:
            done_ids = set(previous["case_id"]) & set(case_ids)
    stats.reused = len(done_ids)
    todo = []
    for rng in plan_chunks(len(cases), batch_size, chunk_size):
        idx = [i for i in rng if case_ids[i] not in done_ids]
        if idx:
            todo.append(([cases[i] for i in idx], [case_ids[i] for i in idx]))
    if stats.reused:
        log(f"resuming: {stats.reused} of {len(cases)} cases already in {store.parts}; "
            f"computing {len(cases) - stats.reused} in {len(todo)} chunks")
    frames = []

    def report(k: int, total: int) -> None:
        if progress is not None:
            progress(stats.reused + k, len(cases))

    report(0, 0)
    try:
        with DeferredInterrupt() as guard:
            for _k, result in executor.run(task, todo, report, guard.hold):
                rows = result.rows
                if store is not None:
                    store.write(rows, result.histories, result.orbits)
                else:
                    frames.append(rows)
                    if result.histories is not None and on_history is not None:
                        on_history(result.histories)
                    if result.orbits is not None and on_orbits is not None:
                        on_orbits(result.orbits)
                stats.computed += len(rows)
                stats.chunks += 1
                stats.wall_time_s += result.wall_time_s
                stats.certificate_s += result.certificate_s
                stats.case_steps += result.case_steps
                guard.release()  # the chunk is safe: a deferred Ctrl-C stops the run here
    except BaseException as exc:
        # resuming is the remedy of an interruption or a crash that left finished cases; a
        # configuration error (a TorchromError) would only stop the rerun the same way
        kept = stats.reused + stats.computed
        if store is not None and kept and not isinstance(exc, TorchromError):
            how = "interrupted" if isinstance(exc, KeyboardInterrupt) else "stopped"
            log(f"{how}: {kept} of {len(cases)} cases are kept in "
                f"{store.parts} ({stats.reused} from before, {stats.computed} computed now); run "
                f"the same command again to resume (only the others are computed)")
        raise
    if store is not None:
        table = store.load()
        for kind, receive in (("histories", on_history), ("orbits", on_orbits)):
            extra = store.load_extra(kind)
            if extra is not None and receive is not None:
                receive(extra)
    else:
        table = pd.concat(frames, ignore_index=True) if frames else None
    if table is None:
        raise TorchromError("no results")
    table = _ordered(table, case_ids, log)
    stats.elapsed_s = time.perf_counter() - t0
    return table, stats
