"""Chunked, resumable, distributed sweeps (torchrom.study.runner) on a fast analytic ROM.

Acceptance (issue 7): a worker killed mid-run, a SIGINT, a truncated part file and a changed model
all end in every case computed exactly once, with numbers identical to an uninterrupted
in-process run (the chunks are the same batches, so equality is exact, not approximate).

One local Dask cluster (2 single-threaded worker processes) serves every cluster test of this
module; the test that kills a worker runs last.
"""

from __future__ import annotations

import glob
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import psutil
import pytest

from torchrom.cli import main
from torchrom.errors import InputError
from torchrom.rom.analytic import van_der_pol_duffing
from torchrom.study import load_sweep_config
from torchrom.study.grid import case_id
from torchrom.study.runner import PartStore, chunk_key, open_executor, plan_chunks
from torchrom.study.sweep import run_description, run_sweep

from .conftest import REPO

# one Van der Pol-Duffing mode, net linear damping α + γ c1: LCO for α < γ, decay above;
# 12 cases in 6 chunks of 2, each chunk at most 1000 steps
CONFIG = """
title = "runner test"
[model]
{model}
[initial]
q0 = 0.5
[integrator]
dt = 0.01
t_end = 10.0
iterations = 3
predictor = "quadratic"
[lco]
rtol = 1e-3
[cases]
gamma = [1.0, 2.0]
alpha = {{start = 0.0, stop = 1.5, num = 6}}
[run]
chunk_size = 2
"""
BUILTIN = 'builtin = "van_der_pol_duffing"\nc1 = -1.0\nd3 = 1.0\nk3 = 0.5'
N_CASES, N_CHUNKS = 12, 6


def write_config(folder, model: str = BUILTIN, text: str = CONFIG):
    path = folder / "sweep.toml"
    path.write_text(text.format(model=model))
    return path


#: the same cases run for 10,000 steps each (no LCO is decided at rtol 1e-12, so no case stops
#: early): chunks of ~0.5 s, so that a SIGINT sent when the first part file appears finds the
#: others still running (with the 1,000-step chunks the whole sweep could finish before it)
SLOW_CONFIG = CONFIG.replace("dt = 0.01", "dt = 0.001").replace("rtol = 1e-3", "rtol = 1e-12")


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    return write_config(tmp_path_factory.mktemp("cfg"))


@pytest.fixture(scope="module")
def reference_run(config, tmp_path_factory):
    """The uninterrupted in-process run: (table read back from its part files, its folder)."""
    cfg = load_sweep_config(config)
    out = tmp_path_factory.mktemp("reference")
    table, timing = run_sweep(cfg, out=out)
    assert timing["computed"] == N_CASES and timing["chunks"] == N_CHUNKS
    assert set(table["status"]) >= {"lco", "decay"}
    return table, out


@pytest.fixture(scope="module")
def reference(reference_run):
    return reference_run[0]


@pytest.fixture(scope="module")
def slow_config(tmp_path_factory):
    return write_config(tmp_path_factory.mktemp("slow"), text=SLOW_CONFIG)


@pytest.fixture(scope="module")
def cluster():
    """A LocalCluster shared by this module's cluster tests (closed, with its processes, after)."""
    import logging

    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None, silence_logs=logging.ERROR) as lc, \
            Client(lc) as client:
        client.run(lambda: __import__("torchrom.study.sweep"))  # import torch once, up front
        yield lc


def test_plan_chunks_depends_only_on_cases_and_sizes():
    assert [len(c) for c in plan_chunks(100, 512)] == [25, 25, 25, 25]  # >= MIN_CHUNK each
    sizes = [len(c) for c in plan_chunks(1003, 512)]
    assert len(sizes) == 8 and max(sizes) - min(sizes) <= 1 and sum(sizes) == 1003
    sizes = [len(c) for c in plan_chunks(10_000, 512)]
    assert len(sizes) == 20 and max(sizes) <= 512  # batch_size bounds a chunk
    assert [len(c) for c in plan_chunks(7, 512, chunk_size=3)] == [3, 3, 1]
    assert plan_chunks(0, 512) == []
    chunks = plan_chunks(1003, 64)
    assert [i for c in chunks for i in c] == list(range(1003))  # contiguous, each case once


def test_case_ids_depend_on_the_model(tmp_path):
    """A changed rom.npz under the same name and configuration gives new case ids and a run
    that refuses the old folder; with a new folder nothing old is reused."""
    vdp = van_der_pol_duffing(c1=-1.0, d3=1.0, k3=0.5)
    vdp.save(tmp_path / "model.npz")
    path = write_config(tmp_path, 'rom = "model.npz"')
    cfg = load_sweep_config(path)
    run_a = run_description(cfg, cfg.build_rom())
    vdp.replace(D3=vdp.D3 * 1.01).save(tmp_path / "model.npz")  # same file name, new model
    run_b = run_description(cfg, cfg.build_rom())
    assert run_a["config_hash"] == run_b["config_hash"]
    assert run_a["model_hash"] != run_b["model_hash"] and run_a["run_key"] != run_b["run_key"]
    case = cfg.cases[0]
    assert case_id(case, run_a["run_key"]) != case_id(case, run_b["run_key"])

    out = tmp_path / "out"
    PartStore(out, run_a).open()
    assert PartStore(out, run_b).check() is False  # a manifest alone (no results) never blocks
    (out / "parts" / "part-0000.parquet").write_bytes(b"a stored chunk")
    with pytest.raises(InputError, match="different configuration .model changed.*--force"):
        PartStore(out, run_b).open()
    assert main(["sweep", str(path), "--out", str(out)]) == 2  # the CLI refuses it too


def test_truncated_and_orphan_parts_are_recomputed(config, reference_run, tmp_path):
    reference, finished = reference_run
    cfg = load_sweep_config(config)
    out = tmp_path / "out"
    shutil.copytree(finished, out)
    parts = sorted((out / "parts").glob("part-*.parquet"))
    assert len(parts) == N_CHUNKS
    data = parts[0].read_bytes()
    parts[0].write_bytes(data[: len(data) // 2])  # truncated
    flipped = bytearray(parts[1].read_bytes())
    flipped[len(flipped) // 2] ^= 0xFF  # same size, one byte corrupted
    parts[1].write_bytes(bytes(flipped))
    parts[2].with_suffix(".json").unlink()  # as if killed between the two renames
    messages = []
    table, timing = run_sweep(cfg, out=out, log=messages.append)
    assert timing["reused"] == N_CASES - 6 and timing["computed"] == 6
    text = "\n".join(messages)
    assert text.count("checksum mismatch") == 2 and "no sidecar" in text
    assert len(list((out / "parts" / "rejected").iterdir())) == 5  # 3 parquet + 2 sidecars
    pd.testing.assert_frame_equal(table, reference)


def test_scheduler_option_runs_on_an_existing_cluster(config, reference, cluster, tmp_path):
    out = tmp_path / "out"
    assert main(["sweep", str(config), "--out", str(out), "--scheduler",
                 cluster.scheduler_address]) == 0
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), reference)


def test_sigint_keeps_finished_chunks_and_resume_matches(slow_config, tmp_path, capsys):
    """`torchrom sweep --workers 2` interrupted by SIGINT after its first finished chunk: exit
    130, finished chunks kept, no worker process left; the rerun (in-process) computes only the
    missing cases and gives exactly the uninterrupted table (:data:`SLOW_CONFIG`)."""
    config = slow_config
    reference, _ = run_sweep(load_sweep_config(config), out=tmp_path / "reference")
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get(
        "PYTHONPATH", "")])}
    # SIGINT's default disposition in the child, as in a terminal: a test run started in the
    # background by a non-interactive shell inherits SIGINT ignored (POSIX), and an ignored
    # signal stays ignored across exec — the sweep would then never see the Ctrl-C
    proc = subprocess.Popen([sys.executable, "-m", "torchrom", "sweep", str(config), "--out",
                             str(out), "--workers", "2"], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 120
    while not glob.glob(str(out / "parts" / "part-*.json")):
        assert proc.poll() is None, proc.communicate()[0]
        assert time.monotonic() < deadline, "no part file within 120 s"
        time.sleep(0.05)
    children = psutil.Process(proc.pid).children(recursive=True)
    assert len(children) >= 2  # the worker processes (and their nannies)
    proc.send_signal(signal.SIGINT)
    output = proc.communicate(timeout=120)[0]
    assert proc.returncode == 130, output
    assert "run the same command again to resume" in output
    gone, alive = psutil.wait_procs(children, timeout=30)
    assert not alive, f"worker processes left running: {alive}"
    kept = len(glob.glob(str(out / "parts" / "part-*.json")))
    assert 1 <= kept < N_CHUNKS, output

    assert main(["sweep", str(config), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    done = 2 * kept
    left = N_CHUNKS - kept
    assert (f"{N_CASES - done} computed in {left} chunk{'' if left == 1 else 's'}, {done} reused"
            in printed)
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), reference)


def test_killed_worker_still_completes_every_case_once(config, reference, cluster, tmp_path):
    """SIGKILL a worker process while it integrates a chunk: the nanny restarts it, the scheduler
    reruns the chunk elsewhere, and the table is exactly the in-process one."""
    cfg = load_sweep_config(config)
    killed = {}
    with open_executor(scheduler=cluster.scheduler_address) as executor:
        client = executor.client
        pids_before = client.run(os.getpid)

        def kill_a_busy_worker(done, total):
            if killed or done == 0:
                return
            busy = [w for w, keys in client.processing().items()
                    if any(str(k).startswith("torchrom-chunk") for k in keys)]
            assert busy, "no chunk was running when the worker was to be killed"
            killed["key"] = [str(k) for k in client.processing()[busy[0]]]
            killed["pid"] = pids_before[busy[0]]
            os.kill(killed["pid"], signal.SIGKILL)

        table, timing = run_sweep(cfg, out=tmp_path / "out", executor=executor,
                                  progress=kill_a_busy_worker)
        assert killed, "the run finished before a worker could be killed"
        # the nanny replaces the killed worker (wait for it, so the cluster is whole again)
        deadline = time.monotonic() + 60
        while True:
            try:
                pids = client.run(os.getpid)
            except OSError:  # a worker that is going away
                pids = {}
            if len(pids) == 2 and killed["pid"] not in pids.values():
                break
            assert time.monotonic() < deadline, "the killed worker was not replaced"
            time.sleep(0.2)
    assert not psutil.pid_exists(killed["pid"]) or psutil.Process(
        killed["pid"]).status() == psutil.STATUS_ZOMBIE
    assert timing["computed"] == N_CASES and timing["chunks"] == N_CHUNKS
    assert table["case_id"].is_unique and len(table) == N_CASES
    ids = {chunk_key(list(table["case_id"][2 * k: 2 * k + 2])) for k in range(N_CHUNKS)}
    assert any(key.endswith(k) for key in killed["key"] for k in ids)  # a chunk of ours died
    pd.testing.assert_frame_equal(table, reference)
    assert np.isfinite(table["last_amplitude"]).all()  # a value for every case, whatever its status


def _malloc_trim_setting():
    import os

    return os.environ.get("MALLOC_TRIM_THRESHOLD_")


def test_local_cluster_workers_keep_glibc_dynamic_mmap_threshold():
    # Dask's default pre-spawn MALLOC_TRIM_THRESHOLD_ fixes glibc's mmap threshold, which made
    # a chunk run 2-2.6x slower in a worker than in-process (benchmarks/bench_dask.py)
    import os

    if "MALLOC_TRIM_THRESHOLD_" in os.environ:
        pytest.skip("MALLOC_TRIM_THRESHOLD_ set in this environment (inherited by the workers)")
    with open_executor(workers=1) as executor:
        values = executor.client.run(_malloc_trim_setting)
    assert list(values.values()) == [None]


@pytest.mark.parametrize("failure, advice", [(InputError("[cases] mach: differs"), False),
                                             (RuntimeError("a crash"), True)])
def test_resume_advice_only_where_resuming_helps(failure, advice, tmp_path):
    """A run that stops on its second chunk keeps the first; "run the same command again to
    resume" is said after a crash, not after a configuration error (a TorchromError: the rerun
    would stop the same way), and not when nothing was kept."""
    from torchrom.study.runner import ChunkResult, run_cases

    def task(cases, case_ids, progress=None):
        if cases[0]["i"] >= 1:
            raise failure
        return ChunkResult(pd.DataFrame({"case_id": case_ids, "i": [c["i"] for c in cases]}))

    for first_fails in (False, True):
        cases = [{"i": i + int(first_fails)} for i in range(2)]
        ids = [f"c{i}" for i in range(2)]
        logged: list[str] = []
        store = PartStore(tmp_path / f"out{int(first_fails)}", {"run_key": "k"})
        with pytest.raises(type(failure)):
            run_cases(task, cases, ids, batch_size=1, store=store, log=logged.append)
        said = any("run the same command again to resume" in line for line in logged)
        assert said == (advice and not first_fails), logged
