"""No lost work (issue 26): two sweeps on one folder, a Ctrl-C at a chunk boundary, a failure
after a finished chunk, --force over a truncated manifest, a hand-edited results table, and the
paper study's sweeps resumed mid-way. Every case of a resumed run is exactly the uninterrupted
run's (the chunks are the same batches, so equality is exact)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys

import pandas as pd
import pytest
import torch

from torchrom.cli import main
from torchrom.errors import InputError
from torchrom.paper.cache import FileCache
from torchrom.paper.study import _lco_sweep
from torchrom.study import load_sweep_config
from torchrom.study import sweep as sweep_mod
from torchrom.study.runner import ChunkResult, PartStore, run_cases
from torchrom.study.sweep import SweepTask, run_description, run_sweep

from .conftest import REPO
from .test_study_runner import N_CASES, N_CHUNKS, write_config


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    return write_config(tmp_path_factory.mktemp("cfg"))


@pytest.fixture(scope="module")
def finished(config, tmp_path_factory):
    """An uninterrupted `torchrom sweep` folder and its table."""
    out = tmp_path_factory.mktemp("finished") / "out"
    assert main(["sweep", str(config), "--out", str(out)]) == 0
    return out, pd.read_parquet(out / "results.parquet")


def _parts(out):
    return sorted((out / "parts").glob("part-*.json"))


def _env():
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO),
                                                         os.environ.get("PYTHONPATH", "")])}


def test_two_concurrent_sweeps_on_one_folder_never_interleave(config, finished, tmp_path):
    """Two `torchrom sweep` processes started together on one folder: the one that comes second
    refuses (exit 2, naming the first one's PID; the lock is held from the folder check to the
    last figure) or, if the first had finished, resumes from it; the table is complete and
    exactly the uninterrupted one, and no part was rejected."""
    reference = finished[1]
    out = tmp_path / "out"
    procs = [subprocess.Popen([sys.executable, "-m", "torchrom", "sweep", str(config), "--out",
                               str(out)], env=_env(), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    results = [(p, *p.communicate(timeout=300)) for p in procs]
    codes = sorted(p.returncode for p in procs)
    assert codes in ([0, 0], [0, 2]), results
    if codes == [0, 2]:
        (loser, _, err), = [r for r in results if r[0].returncode == 2]
        (winner, _, _), = [r for r in results if r[0].returncode == 0]
        line = err.strip().splitlines()[-1]
        assert line.startswith(f"torchrom sweep: error: {out}: in use by another torchrom run "
                               f"(PID {winner.pid}"), err
    else:  # serialised: one of them found the other's finished parts
        assert any(f"0 computed in 0 chunks, {N_CASES} reused" in o for _, o, _ in results)
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), reference)
    assert len(_parts(out)) == N_CHUNKS and not (out / "parts" / "rejected").exists()
    assert not (out / ".torchrom.lock").exists()


def test_ctrl_c_at_a_chunk_boundary_keeps_the_chunk(config, finished, tmp_path, monkeypatch):
    """A SIGINT after a chunk's integration, while its rows are built: the chunk is stored
    before the interrupt takes effect, the message counts it, and the rerun reuses it."""
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        pytest.skip("SIGINT is not Python's default handler in this test run")
    reference = finished[1]
    cfg = load_sweep_config(config)
    rows = sweep_mod.result_rows

    def interrupted_rows(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C right at the end of the first chunk
        return rows(*args, **kwargs)

    monkeypatch.setattr(sweep_mod, "result_rows", interrupted_rows)
    out, messages = tmp_path / "out", []
    with pytest.raises(KeyboardInterrupt):
        run_sweep(cfg, out=out, log=messages.append)
    assert len(_parts(out)) == 1
    assert messages[-1].startswith(f"interrupted: 2 of {N_CASES} cases are kept in "
                                   f"{out / 'parts'} (0 from before, 2 computed now)")
    monkeypatch.setattr(sweep_mod, "result_rows", rows)
    table, timing = run_sweep(cfg, out=out)
    assert timing["reused"] == 2 and timing["computed"] == N_CASES - 2
    pd.testing.assert_frame_equal(table, reference)


def test_a_failure_after_a_finished_chunk_keeps_it(config, finished, tmp_path, monkeypatch):
    """The second chunk raises (as `--threads 100000` did, an allocation failure): the first
    chunk's part stays, the message says so, and the rerun computes only the others."""
    reference = finished[1]
    cfg = load_sweep_config(config)
    call = SweepTask.__call__
    calls = []

    def failing(self, cases, ids, progress=None):
        calls.append(ids)
        if len(calls) == 2:
            raise MemoryError("malloc of size 192 failed")
        return call(self, cases, ids, progress)

    monkeypatch.setattr(SweepTask, "__call__", failing)
    out, messages = tmp_path / "out", []
    with pytest.raises(MemoryError):
        run_sweep(cfg, out=out, log=messages.append)
    assert len(_parts(out)) == 1 and messages[-1].startswith(f"stopped: 2 of {N_CASES} cases")
    monkeypatch.setattr(SweepTask, "__call__", call)
    table, timing = run_sweep(cfg, out=out)
    assert timing["reused"] == 2
    pd.testing.assert_frame_equal(table, reference)


def test_threads_beyond_the_cores_are_refused_before_any_work(config, tmp_path, capsys):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main(["sweep", str(config), "--out", str(out), "--threads", "100000"])
    assert exc.value.code == 2 and not out.exists()
    assert "--threads: expected a number of threads from 1 to" in capsys.readouterr().err


def test_force_after_a_truncated_manifest_keeps_this_runs_parts(config, finished, tmp_path,
                                                                capsys):
    """A truncated parts/manifest.json: the parts' own sidecars prove they are this run's, so
    the rerun resumes from them, with or without --force; a part of another run beside them
    is refused without --force and is the only one --force deletes."""
    out = tmp_path / "out"
    shutil.copytree(finished[0], out)
    manifest = out / "parts" / "manifest.json"
    manifest.write_text(manifest.read_text()[:20])
    for force in ([], ["--force"]):
        assert main(["sweep", str(config), "--out", str(out), *force]) == 0
        assert f"0 computed in 0 chunks, {N_CASES} reused" in capsys.readouterr().out
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), finished[1])

    cfg = load_sweep_config(config)
    run = run_description(cfg, cfg.build_model())
    foreign = out / "parts" / "part-0123456789abcdef.json"
    foreign.write_text(json.dumps({"run_key": "another"}))
    foreign.with_suffix(".parquet").write_bytes(b"another run's chunk")
    manifest.write_text("{")
    with pytest.raises(InputError, match="manifest.json is unreadable and 1 parts are not"):
        PartStore(out, run).check()
    messages = []
    store = PartStore(out, run, warn=messages.append)
    store.open(force=True)
    assert messages == [f"--force: removed 1 parts of a previous configuration (run key "
                        f"changed) from {out / 'parts'}"]
    assert not foreign.exists() and len(_parts(out)) == N_CHUNKS
    assert len(store.load()) == N_CASES


def test_an_edited_results_table_is_not_replaced_without_force(config, finished, tmp_path,
                                                               capsys):
    out = tmp_path / "out"
    shutil.copytree(finished[0], out)
    assert main(["sweep", str(config), "--out", str(out)]) == 0  # unchanged: rewritten
    capsys.readouterr()
    csv = out / "results.csv"
    edited = csv.read_text().replace("lco", "LCO (checked by hand)", 1)
    csv.write_text(edited)
    assert main(["sweep", str(config), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{csv}: changed since this sweep wrote it" in err and "--force" in err
    assert csv.read_text() == edited  # kept as the user left it
    assert main(["sweep", str(config), "--out", str(out), "--force"]) == 0
    assert f"0 computed in 0 chunks, {N_CASES} reused" in capsys.readouterr().out
    assert csv.read_text() != edited


def test_stored_orbits_are_handed_back_on_resume(tmp_path):
    """Harmonic-balance orbits are stored with their chunk's rows: a resumed run hands every
    case's orbit to ``on_orbits``, those of the reused chunks too."""
    def task(cases, ids, progress=None):
        rows = pd.DataFrame({"case_id": ids, "x": [c["x"] for c in cases]})
        return ChunkResult(rows, orbits=pd.DataFrame({"case_id": ids, "omega": [
            2.0 * c["x"] for c in cases]}))

    cases = [{"x": float(i)} for i in range(6)]
    ids = [f"c{i}" for i in range(6)]
    store = PartStore(tmp_path, {"run_key": "k"})

    def interrupted(cases, ids, progress=None):
        if ids[0] != "c0":
            raise KeyboardInterrupt
        return task(cases, ids, progress)

    with pytest.raises(KeyboardInterrupt):
        run_cases(interrupted, cases, ids, chunk_size=2, store=store)
    got = []
    table, stats = run_cases(task, cases, ids, chunk_size=2, store=store, on_orbits=got.append)
    assert stats.reused == 2 and stats.computed == 4
    (orbits,) = got
    both = table.merge(orbits, on="case_id")
    assert sorted(both["case_id"]) == ids and (both["omega"] == 2 * both["x"]).all()


def test_paper_study_sweep_resumes_mid_way(config, finished, tmp_path, monkeypatch):
    """A sweep of `torchrom paper` (:func:`torchrom.paper.study._lco_sweep`) interrupted after
    its first chunk resumes from its parts in ``sweeps/<name>/parts``: before, the study's
    sweeps restarted from zero (243 s recomputed); a changed solver setting (the study's own
    adjustment, which the configuration's hash does not see) replaces them instead."""
    cfg = load_sweep_config(config)
    model = cfg.build_model()
    cache = FileCache(tmp_path)
    call = SweepTask.__call__
    calls = []

    def interrupted(self, cases, ids, progress=None):
        calls.append(ids)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return call(self, cases, ids, progress)

    monkeypatch.setattr(SweepTask, "__call__", interrupted)
    args = (cache, cfg, model, model.content_hash(), "cpu", torch.float64)
    with pytest.raises(KeyboardInterrupt):
        _lco_sweep(*args, lambda s: None)
    assert len(_parts(tmp_path / "sweeps" / "lco")) == 2
    monkeypatch.setattr(SweepTask, "__call__", call)
    table, histories, info, orbits = _lco_sweep(*args, lambda s: None)
    assert info["resumed_cases"] == 4 and info["reused"] is False and orbits is None
    ref = finished[1]
    cols = [c for c in ref.columns if c != "case_id"]  # ids hash the study's key too
    pd.testing.assert_frame_equal(table[cols], ref[cols])
    # the parts are keyed by the study's cache key (_sweep_key): another key never reuses them
    _, timing = run_sweep(cfg, model=model, out=tmp_path / "sweeps" / "lco", force=True,
                          context="another key")
    assert timing["reused"] == 0 and len(_parts(tmp_path / "sweeps" / "lco")) == N_CHUNKS


def test_concurrent_paper_runs_refuse_the_second(tmp_path):
    from torchrom.locks import folder_lock
    from torchrom.paper.study import run_paper

    code = ("import sys, time\nfrom torchrom.locks import folder_lock\n"
            "with folder_lock(sys.argv[1], 'torchrom paper'):\n"
            "    print('held', flush=True)\n    time.sleep(30)\n")
    proc = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], env=_env(),
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        with pytest.raises(InputError, match=f"in use by another torchrom run .PID {proc.pid}"):
            run_paper(tmp_path, quick=True, log=lambda s: None)
    finally:
        proc.kill()
        proc.wait()
    with folder_lock(tmp_path):  # the stale lock of the killed holder is recovered
        pass
    assert list(tmp_path.iterdir()) == []
