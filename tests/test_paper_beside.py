"""The study's second process (torchrom.paper.beside) and its deferred cache: a job's value,
files and log lines come back to the study's process, which alone writes the manifest; errors
come back as they were raised; with one process the job runs in place at its stage."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from torchrom.errors import InputError
from torchrom.io import write_text_atomic
from torchrom.limits import usable_cpus
from torchrom.paper.beside import ENV, Beside, study_processes
from torchrom.paper.cache import MANIFEST, DeferredCache, FileCache

KEY = FileCache.key({"stage": "beside-test"})


def write_job(cache, text, *, log):
    """A stage as the study writes one: reuse its file if cached, else write it."""
    found = cache.get("tables/job.txt", KEY)
    if found is not None:
        log("reused")
        return found.read_text()
    log(f"writing {text} in process {os.getpid()}")
    cache.put("tables/job.txt", KEY, lambda p: write_text_atomic(p, text))
    return text


def failing_job(cache, *, log):
    raise InputError("job: expected something else")


def pid_job(cache, *, log):
    """A stage whose file is never cached (it needs the worker, where there is one)."""
    assert cache.get("tables/never.txt", KEY) is None
    return os.getpid()


def test_deferred_cache_writes_files_but_not_the_manifest(tmp_path):
    main = FileCache(tmp_path)
    main.put("a.txt", KEY, lambda p: write_text_atomic(p, "main"))
    other = DeferredCache(tmp_path)
    assert other.get("a.txt", KEY).read_text() == "main"  # reads what the study wrote
    other.put("b.txt", KEY, lambda p: write_text_atomic(p, "worker"))
    assert (tmp_path / "b.txt").read_text() == "worker"
    assert "b.txt" not in json.loads((tmp_path / MANIFEST).read_text())["files"]
    main.adopt(other.written(), other.hits)
    files = json.loads((tmp_path / MANIFEST).read_text())["files"]
    assert set(files) == {"a.txt", "b.txt"}
    assert FileCache(tmp_path).get("b.txt", KEY).read_text() == "worker"
    assert "b.txt" in main.built and "a.txt" in main.hits


@pytest.mark.parametrize("processes", [1, 2])
def test_a_job_comes_back_with_its_files_and_lines(tmp_path, processes):
    cache = FileCache(tmp_path)
    lines = []
    with Beside(tmp_path, False, processes) as beside:
        job = beside.submit(write_job, "text")
        pid = beside.submit(pid_job)
        assert job.result(cache, lines.append) == "text"
        assert job.result(cache, lines.append) == "text"  # collected once
        assert (pid.result(cache, lines.append) == os.getpid()) == (processes == 1)
    # the job's own line, and a line saying the study waits wherever it had to (for either job)
    own = [ln for ln in lines if "waiting" not in ln]
    assert len(own) == 1 and own[0].startswith("writing text") and len(lines) <= 3
    assert json.loads((tmp_path / MANIFEST).read_text())["files"]["tables/job.txt"]["key"] == KEY
    # a second study reuses the job's file through the manifest the first one wrote, in its
    # own process (a probe finds every file cached: no worker started)
    again, lines2 = FileCache(tmp_path), []
    with Beside(tmp_path, False, processes) as beside:
        job = beside.submit(write_job, "other")
        assert job.future is None
        assert job.result(again, lines2.append) == "text"
        assert getattr(beside.pool, "_processes", None) in (None, {})
    assert lines2 == ["reused"] and again.hits == ["tables/job.txt"]


def test_probing_raises_where_a_file_would_be_built(tmp_path):
    from torchrom.paper.cache import CacheMiss, probing

    cache = FileCache(tmp_path)
    cache.put("a.txt", KEY, lambda p: write_text_atomic(p, "a"))
    with probing():
        assert cache.get("a.txt", KEY) is not None
        with pytest.raises(CacheMiss, match="b.txt"):
            cache.get("b.txt", KEY)
        with pytest.raises(CacheMiss, match="a.txt"):  # another key: a miss
            cache.get("a.txt", FileCache.key({"other": 1}))
        with pytest.raises(CacheMiss):
            cache.put("c.txt", KEY, lambda p: write_text_atomic(p, "c"))
    assert not (tmp_path / "c.txt").exists()
    assert cache.get("b.txt", KEY) is None  # outside the block: a plain miss


def blas_threads_job(cache, *, log):
    """The worker's BLAS threads: NumPy's and SciPy's OpenBLAS (both loaded here); never
    cached, so it runs in the worker."""
    import scipy.linalg  # noqa: F401 - loads SciPy's own OpenBLAS

    assert cache.get("tables/never.txt", KEY) is None
    from threadpoolctl import threadpool_info

    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def _blas_threads():
    from threadpoolctl import threadpool_info

    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_two_processes_keep_to_one_blas_thread_each(tmp_path, monkeypatch):
    """Two processes on two cores: a BLAS call on two threads waits for the core the other
    process holds (measured 57 s instead of 1.5 s for the model stage's RFA fit on a loaded
    machine), so from the first job on the study's process and the worker each use one BLAS
    thread; the study's own limits and environment are restored afterwards."""
    import scipy.linalg  # noqa: F401 - SciPy's OpenBLAS loaded in the study's process too
    from threadpoolctl import threadpool_limits

    from torchrom.paper.beside import BLAS_ENV

    monkeypatch.delenv(BLAS_ENV, raising=False)
    with threadpool_limits(limits=2, user_api="blas"):  # as on a 2-core machine, any machine
        before = _blas_threads()
        assert before and max(before) == 2
        with Beside(tmp_path, False, 2) as beside:
            job = beside.submit(blas_threads_job)
            assert max(_blas_threads()) == 1
            worker = job.result(FileCache(tmp_path), print)
            assert job.future is not None and worker and max(worker) == 1
        assert _blas_threads() == before and BLAS_ENV not in os.environ


def test_a_failing_job_raises_its_own_error_in_the_study(tmp_path):
    with pytest.raises(InputError, match="job: expected something else"):
        with Beside(tmp_path, False, 2) as beside:
            beside.submit(failing_job).result(FileCache(tmp_path), print)


def test_study_processes_from_the_environment(monkeypatch):
    monkeypatch.setenv(ENV, "1")
    assert study_processes() == 1
    monkeypatch.setenv(ENV, "2")
    assert study_processes() == 2
    monkeypatch.delenv(ENV)
    assert study_processes() == (2 if usable_cpus() >= 2 else 1)
    monkeypatch.setenv(ENV, "four")
    with pytest.raises(InputError, match=ENV):
        study_processes()


@pytest.mark.parametrize("kind", ["quick", "full"])
def test_stage_references_by_process_count(kind):
    """The ETA's reference run: the same stages in the same order either way; in one process
    the stages of the second process count their whole time (a one-process study showed
    "ETA 8 s" before the 27 s wing variant), and no stage is cheaper there."""
    from torchrom.paper.study import ONE_PROCESS_SECONDS, study_stages

    two, one = dict(study_stages(kind, False, 2)), dict(study_stages(kind, False, 1))
    assert list(two) == list(one)
    assert set(ONE_PROCESS_SECONDS[kind]) < set(two)
    assert all(one[k] >= two[k] for k in two)
    assert sum(one.values()) > sum(two.values()) + 40.0


def test_paper_refuses_a_bad_process_count_before_writing(tmp_path):
    """The real CLI: one line naming the variable, exit 2, no output folder."""
    out = tmp_path / "p"
    res = subprocess.run([sys.executable, "-m", "torchrom", "paper", "--quick", "--out",
                          str(out)], capture_output=True, text=True, timeout=120,
                         env={**os.environ, ENV: "0"})
    assert res.returncode == 2
    err = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(err) == 1 and ENV in err[0] and "expected 1 or 2" in err[0], res.stderr
    assert not out.exists()
