"""A Dask cluster that is really one (torchrom.study.cluster, issue 47, item 5).

- The comparison of code identities, on hand-written identities: equal code passes, every
  differing key is named with the worker's and the client's value, workers with the same
  difference are named together, a worker that cannot report is named.
- :func:`files_hash` of copies of the package: a byte-identical copy hashes like the
  installation, a copy with one comment added does not, and a Python that imports that copy
  reports its hash (:func:`source_hash`).
- Real clusters of separate processes (``dask scheduler`` and ``dask worker`` from the venv, in a
  folder of their own: tests/dask_processes.py), driven by ``torchrom sweep --scheduler`` in a
  subprocess from a third folder, with a model read from a ROM file:
  workers with another torchrom version or other torchrom files are refused on connect in one
  line (exit 2, nothing written); a worker with other files that joins after the connect check
  fails its chunks with the same message and stores nothing; and a sweep whose busy worker is
  SIGKILLed (nanny and worker process) once a part is stored finishes on the other worker with
  every row, identical to an in-process run of the same configuration.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from torchrom.cli import main
from torchrom.rom.analytic import van_der_pol_duffing
from torchrom.study.cluster import (
    IDENTITY_KEYS,
    code_identity,
    differences,
    files_hash,
    mismatch_message,
)

from .dask_processes import DaskProcesses

# -- the comparison ------------------------------------------------------------------------------
CLIENT = {"torchrom": "0.1.0", "torchrom source": "1111aaaa2222bbbb", "torch": "2.3.1",
          "dask": "2024.8.0", "distributed": "2024.8.0", "python": "3.11"}


def test_equal_code_passes():
    assert mismatch_message("tcp://s:8786", CLIENT, {"tcp://a:1": dict(CLIENT),
                                                     "tcp://b:2": dict(CLIENT)}) == ""
    assert mismatch_message("tcp://s:8786", CLIENT, {}) == ""  # no workers yet: their chunks check


def test_every_difference_is_named_with_both_values():
    worker = {**CLIENT, "torch": "2.1.0", "torchrom source": "9999ffff0000eeee"}
    assert differences(CLIENT, worker) == ("torchrom source 9999ffff0000eeee (client "
                                           "1111aaaa2222bbbb), torch 2.1.0 (client 2.3.1)")
    missing = {k: v for k, v in CLIENT.items() if k != "dask"}
    assert differences(CLIENT, missing) == "dask missing (client 2024.8.0)"


def test_refusal_is_one_line_naming_workers_grouped_by_difference():
    other = {**CLIENT, "torchrom": "0.2.0", "torchrom source": "3333cccc4444dddd"}
    workers = {"tcp://c:3": dict(CLIENT), "tcp://a:1": other, "tcp://b:2": dict(other),
               "tcp://d:4": ModuleNotFoundError("No module named 'torchrom'")}
    msg = mismatch_message("tcp://s:8786", CLIENT, workers)
    assert "\n" not in msg
    assert msg.startswith("--scheduler tcp://s:8786: 3 of 4 workers run other code than this "
                          "client (torchrom 0.1.0 (source 1111aaaa2222bbbb), torch 2.3.1, ")
    assert ("tcp://a:1, tcp://b:2: torchrom 0.2.0 (client 0.1.0), torchrom source "
            "3333cccc4444dddd (client 1111aaaa2222bbbb)") in msg
    assert "tcp://d:4: cannot report its torchrom code (ModuleNotFoundError" in msg
    assert "tcp://c:3" not in msg  # the worker that runs the client's code is not named


def test_code_identity_of_this_process():
    import dask
    import torch

    import torchrom

    ident = code_identity()
    assert tuple(ident) == IDENTITY_KEYS
    assert ident["torchrom"] == torchrom.__version__ and ident["torch"] == torch.__version__
    assert ident["dask"] == dask.__version__
    assert ident["python"] == f"{sys.version_info.major}.{sys.version_info.minor}"


# -- the source hash -----------------------------------------------------------------------------
def _copy_package(dest: Path, version: str | None = None, comment: str | None = None) -> Path:
    """A copy of the installed torchrom package under ``dest`` (for PYTHONPATH), with another
    version number and/or a comment added to one module."""
    import torchrom

    shutil.copytree(Path(torchrom.__file__).parent, dest / "torchrom",
                    ignore=shutil.ignore_patterns("__pycache__"))
    if version is not None:
        (dest / "torchrom" / "_version.py").write_text(f'__version__ = "{version}"\n')
    if comment is not None:
        errors = dest / "torchrom" / "errors.py"
        errors.write_text(errors.read_text() + f"# {comment}\n")
    return dest


def _hash_of(package_root: Path) -> str:
    return files_hash(package_root / "torchrom")


def test_source_hash_names_the_files_not_the_folder(tmp_path):
    """A copy with the same files hashes like the installation (also as a Python that imports
    the copy reports it), one with a comment added does not."""
    import torchrom

    same = _copy_package(tmp_path / "same")
    installed = files_hash(Path(torchrom.__file__).parent)  # the files as they are now
    edited = _copy_package(tmp_path / "edited", comment="a local edit")
    assert _hash_of(same) == installed
    assert _hash_of(edited) != installed
    code = ("import sys, torchrom; from torchrom.study.cluster import source_hash; "
            "assert torchrom.__file__.startswith(sys.argv[1]), torchrom.__file__; "
            "print(source_hash())")
    reported = subprocess.run([sys.executable, "-c", code, str(edited)], check=True, text=True,
                              env={**os.environ, "PYTHONPATH": str(edited)},
                              capture_output=True, cwd=edited).stdout.strip()
    assert reported == _hash_of(edited)


# -- real clusters -------------------------------------------------------------------------------
CONFIG = """
title = "cluster test"
[model]
rom = "model.npz"
[initial]
q0 = 0.5
[integrator]
dt = 0.005
t_end = 40.0
iterations = 3
predictor = "quadratic"
[lco]
rtol = 1e-3
[cases]
gamma = 2.0
alpha = [0.0, 0.3, 0.6, 0.9, 1.2, 1.5, 2.5, 3.0]
[run]
chunk_size = 1
"""
#: two coupled Van der Pol–Duffing modes: mode 1's net linear damping α + γ c1 = α − 2 gives an
#: LCO for α < 2 and a decay above; 8 cases in 8 chunks of ~0.5 s each
N_CASES = 8


@pytest.fixture(scope="module")
def config(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("model")
    van_der_pol_duffing(frequencies_hz=[1.0, 2.3], c1=[-1.0, 0.1], d3=[1.0, 1.0],
                        k3=[0.5, 0.0], coupling=[[0.0, 4.0], [4.0, 0.0]]).save(
        folder / "model.npz")
    (folder / "sweep.toml").write_text(CONFIG)
    return folder / "sweep.toml"


@pytest.fixture(scope="module")
def reference(config, tmp_path_factory) -> pd.DataFrame:
    """The in-process run of the same configuration."""
    out = tmp_path_factory.mktemp("reference") / "out"
    assert main(["sweep", str(config), "--out", str(out)]) == 0
    table = pd.read_parquet(out / "results.parquet")
    assert set(table["status"]) == {"lco", "decay"}
    return table


@pytest.fixture
def cluster(tmp_path):
    """A cluster of separate processes in its own folder; every process ends with the test."""
    with DaskProcesses(tmp_path / "cluster") as processes:
        processes.start_scheduler()
        yield processes


def _sweep(config: Path, out: Path, address: str) -> subprocess.Popen:
    """``torchrom sweep CONFIG --out OUT --scheduler ADDRESS`` in a subprocess, run from a
    folder that is neither the configuration's nor the cluster's."""
    cwd = out.parent / "client"
    cwd.mkdir(parents=True, exist_ok=True)
    return subprocess.Popen([sys.executable, "-m", "torchrom", "sweep", str(config), "--out",
                             str(out), "--scheduler", address], cwd=cwd, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _error_line(stderr: str) -> str:
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def test_workers_with_other_code_are_refused_on_connect(config, cluster, tmp_path):
    versioned = _copy_package(tmp_path / "versioned", version="0.1.0.post99")
    edited = _copy_package(tmp_path / "edited", comment="a local edit")
    cluster.start_worker("versioned", env={"PYTHONPATH": str(versioned)})
    cluster.start_worker("edited", env={"PYTHONPATH": str(edited)})
    addresses = cluster.wait_for_workers(2)
    out = tmp_path / "out"
    proc = _sweep(config, out, cluster.address)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 2, stdout + stderr
    line = _error_line(stderr)
    own = code_identity()
    # the client's files are hashed by the client (files of this tree may change meanwhile)
    client_hash = re.search(r"\(torchrom \S+ \(source ([0-9a-f]{16})\)", line).group(1)
    assert line.startswith(f"torchrom sweep: error: --scheduler {cluster.address}: 2 of 2 "
                           f"workers run other code than this client (torchrom "
                           f"{own['torchrom']} (source {client_hash}), torch {own['torch']}, "
                           f"dask {own['dask']}, distributed {own['distributed']}, python "
                           f"{own['python']}): "), line
    assert (f"{addresses['versioned']}: torchrom 0.1.0.post99 (client {own['torchrom']}), "
            f"torchrom source {_hash_of(versioned)} (client {client_hash})") in line
    assert (f"{addresses['edited']}: torchrom source {_hash_of(edited)} (client "
            f"{client_hash})") in line
    assert line.endswith("every worker needs the same torchrom files, torch, dask, "
                         "distributed and Python as the client (docs/guide/scale.md)")
    assert not (out / "parts").exists()  # nothing stored under this run's key


def test_a_late_worker_with_other_code_stores_nothing(config, cluster, tmp_path):
    """No worker at connect (the check passes), then one with other files joins: every chunk
    refuses to run on it, naming it; the run fails (exit 2) with no part stored."""
    edited = _copy_package(tmp_path / "edited", comment="a local edit")
    out = tmp_path / "out"
    proc = _sweep(config, out, cluster.address)
    # connected (the run's first line names the cluster) before the worker starts
    first = ""
    while f"Dask cluster at {cluster.address}" not in first:
        first = proc.stdout.readline()
        assert first, proc.communicate()
    cluster.start_worker("edited", env={"PYTHONPATH": str(edited)})
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 2, stdout + stderr
    address = cluster.worker_addresses()["edited"]
    assert re.search(f"failed on the cluster: TorchromError: worker {address} runs other code "
                     f"than the client: torchrom source {_hash_of(edited)} \\(client "
                     f"[0-9a-f]{{16}}\\)", stderr), stderr
    assert "Traceback" not in stderr
    assert not list((out / "parts").glob("part-*"))


def test_a_killed_worker_leaves_every_row(config, reference, cluster, tmp_path):
    """Two workers; once a chunk is stored, the worker holding a chunk of the sweep is SIGKILLed
    with its nanny (a lost machine): the scheduler gives its chunks to the other worker and the
    sweep finishes with every row, identical to the in-process run (same chunks, same numbers),
    every LCO certified as there."""
    cluster.start_worker("w1")
    cluster.start_worker("w2")
    cluster.wait_for_workers(2)
    client = cluster.client()
    # docs/guide/scale.md's dask.yaml keeps Dask's MALLOC_TRIM_THRESHOLD_ out of the workers:
    # they see what the environment that started them holds (unset, or a shell's own value)
    assert set(client.run(os.environ.get, "MALLOC_TRIM_THRESHOLD_").values()) == \
        {os.environ.get("MALLOC_TRIM_THRESHOLD_")}
    out = tmp_path / "out"
    proc = _sweep(config, out, cluster.address)
    deadline = time.monotonic() + 120
    while not list((out / "parts").glob("part-*.json")):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no part stored within 120 s"
        time.sleep(0.05)
    busy = None
    while busy is None:
        names = {a: n for n, a in cluster.worker_addresses().items()}
        busy = next(((names[w], [str(k) for k in keys])
                     for w, keys in client.processing().items()
                     if any(str(k).startswith("torchrom-chunk") for k in keys)), None)
        assert proc.poll() is None and time.monotonic() < deadline, "no chunk left to lose"
    stored_before = len(list((out / "parts").glob("part-*.json")))
    cluster.kill_worker(busy[0])
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stdout + stderr
    assert stored_before < N_CASES  # the kill came mid-run
    table = pd.read_parquet(out / "results.parquet")
    pd.testing.assert_frame_equal(table, reference)
    assert len(table) == N_CASES and table["case_id"].is_unique
    assert np.isfinite(table["last_amplitude"]).all()
    assert table.loc[table["status"] == "lco", "certified"].all()
    # the chunks the killed worker held were computed again and stored
    stored = {json.loads(p.read_text())["case_ids"][0] for p in (out / "parts").glob("part-*.json")}
    assert len(stored) == N_CASES
    for key in busy[1]:
        assert (out / "parts" / f"part-{key.rsplit('-', 1)[1]}.json").is_file(), key
    assert f"{N_CASES} computed in {N_CASES} chunks, 0 reused" in stdout
