"""An existing Dask cluster (``--scheduler ADDR``) runs a sweep only if every worker runs this
client's code.

A chunk's rows are stored under the client's run key (:mod:`torchrom.study.runner`), which
hashes the configuration, the model and the precision but not the code that integrates them: a
worker with another torchrom or torch would store its numbers under that key, and a resumed
sweep would mix them with this client's. So, on connect, :func:`check_workers` asks every
worker for its :func:`code_identity` — Python (major.minor), dask, distributed, torch, torchrom
and the SHA-256 of torchrom's installed files (:func:`source_hash`: the same version number
with edited files is other code) — and refuses any difference from the client's in one line
naming the workers and the versions (InputError). Each chunk checks its worker once more
(:func:`check_this_worker`), so a worker that joins the cluster later cannot store results of
other code either: its chunks fail with the same message.

Dask compares its own packages when a client connects, and only warns
(``Client.get_versions(check=True)`` too); the keys here are those that decide a sweep's
numbers or the wire protocol.
"""

from __future__ import annotations

import functools
import hashlib
import sys
from pathlib import Path

from ..errors import InputError, TorchromError

#: the keys of :func:`code_identity`, in the order a refusal names them
IDENTITY_KEYS = ("torchrom", "torchrom source", "torch", "dask", "distributed", "python")


def _package_file(path: Path, root: Path) -> bool:
    """A file that is part of the installed package (not a byte-code cache or an editor's)."""
    rel = path.relative_to(root)
    return (path.is_file() and "__pycache__" not in rel.parts
            and path.suffix not in (".pyc", ".pyo")
            and not any(p.startswith(".") for p in rel.parts) and not path.name.endswith("~"))


def files_hash(root: Path) -> str:
    """SHA-256 (first 16 hex digits) of the package files under ``root``: each file's path
    relative to ``root`` and its bytes, in path order."""
    root = Path(root)
    h = hashlib.sha256()
    for path in sorted(p for p in root.rglob("*") if _package_file(p, root)):
        h.update(path.relative_to(root).as_posix().encode() + b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:16]


@functools.cache
def source_hash() -> str:
    """:func:`files_hash` of the imported torchrom package, computed once per process (the
    files as they are when first asked)."""
    import torchrom

    return files_hash(Path(torchrom.__file__).resolve().parent)


def code_identity() -> dict[str, str]:
    """What must be equal in the client and every worker (see the module docstring)."""
    import dask
    import distributed
    import torch

    import torchrom

    return {"torchrom": torchrom.__version__, "torchrom source": source_hash(),
            "torch": torch.__version__, "dask": dask.__version__,
            "distributed": distributed.__version__,
            "python": f"{sys.version_info.major}.{sys.version_info.minor}"}


def describe(identity: dict[str, str]) -> str:
    """``torchrom 0.1.0 (source 1a2b…), torch 2.3.1, dask …`` in :data:`IDENTITY_KEYS` order."""
    parts = []
    for key in IDENTITY_KEYS:
        if key == "torchrom source":
            continue
        text = f"{key} {identity.get(key, 'missing')}"
        if key == "torchrom":
            text += f" (source {identity.get('torchrom source', 'missing')})"
        parts.append(text)
    return ", ".join(parts)


def differences(client: dict[str, str], worker: dict[str, str] | BaseException) -> str:
    """How a worker's identity differs from the client's, e.g. ``torch 2.1.0 (client
    2.3.1)``; an exception (the worker could not report one) is described; "" when equal."""
    if isinstance(worker, BaseException):
        return (f"cannot report its torchrom code ({type(worker).__name__}: {worker}; torchrom "
                f"missing or older than this client's)")
    return ", ".join(f"{key} {worker.get(key, 'missing')} (client {client.get(key, 'missing')})"
                     for key in IDENTITY_KEYS if worker.get(key) != client.get(key))


def mismatch_message(address: str, client: dict[str, str],
                     workers: dict[str, dict[str, str] | BaseException]) -> str:
    """One line naming the workers (grouped by their difference) whose code differs from the
    client's; "" when every worker runs the client's code."""
    groups: dict[str, list[str]] = {}
    for worker in sorted(workers):
        diff = differences(client, workers[worker])
        if diff:
            groups.setdefault(diff, []).append(worker)
    if not groups:
        return ""
    bad = sum(len(v) for v in groups.values())
    listed = "; ".join(f"{', '.join(names)}: {diff}" for diff, names in groups.items())
    return (f"--scheduler {address}: {bad} of {len(workers)} workers run other code than this "
            f"client ({describe(client)}): {listed}; every worker needs the same torchrom "
            f"files, torch, dask, distributed and Python as the client "
            f"(docs/guide/scale.md)")


def check_workers(client, address: str) -> dict[str, str]:
    """Refuse (InputError, one line) when a worker of the cluster behind ``client`` runs other
    code than this process; returns this process's :func:`code_identity`, which every chunk
    checks again on its worker (:func:`check_this_worker`). A cluster without workers yet
    passes: its workers are checked by their chunks."""
    own = code_identity()
    workers = client.run(code_identity, on_error="return")
    message = mismatch_message(address, own, workers)
    if message:
        raise InputError(message)
    return own


def check_this_worker(expected: dict[str, str]) -> None:
    """In a worker, before a chunk runs: TorchromError when this process's code differs from
    the client's (``expected``), naming this worker, so that its rows are never stored."""
    diff = differences(expected, code_identity())
    if diff:
        from distributed import get_worker

        raise TorchromError(f"worker {get_worker().address} runs other code than the client: "
                            f"{diff}; every worker needs the same torchrom files, torch, dask, "
                            f"distributed and Python as the client (docs/guide/scale.md)")
