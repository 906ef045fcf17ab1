"""One torchrom run per folder (torchrom.locks): refusal naming the holder's PID, waiting,
stale locks of dead processes, re-entrancy, the fallback without flock (exclusive creation,
host-aware takeover, many processes at once), and the deferred Ctrl-C (torchrom.interrupts)."""

from __future__ import annotations

import errno
import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from torchrom import locks
from torchrom.errors import InputError
from torchrom.interrupts import DeferredInterrupt
from torchrom.locks import LOCK_NAME, TAKEOVER_SUFFIX, FolderBusy, folder_lock, read_holder

#: a second process that holds the lock of argv[1] for argv[2] seconds (prints "held" once it
#: has it, "released" after)
HOLDER = """
import sys, time
from torchrom.locks import folder_lock
with folder_lock(sys.argv[1], "a test"):
    print("held", flush=True)
    time.sleep(float(sys.argv[2]))
print("released", flush=True)
"""


def _hold(folder, seconds: float) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(folder), str(seconds)],
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_lock_is_held_for_the_block_and_removed_after(tmp_path):
    folder = tmp_path / "out"
    with folder_lock(folder, "a test"):
        holder = read_holder(folder / LOCK_NAME)
        assert holder["pid"] == str(os.getpid()) and holder["what"] == "a test"
        with folder_lock(folder):  # re-entrant in the same process
            assert (folder / LOCK_NAME).is_file()
        assert (folder / LOCK_NAME).is_file()  # still held by the outer block
    assert not folder.exists()  # created for the lock and left empty: removed again
    folder.mkdir()
    with folder_lock(folder):
        (folder / "result.csv").write_text("x")
    assert list(folder.iterdir()) == [folder / "result.csv"]  # the lock file is gone


def test_a_second_process_is_refused_with_the_holders_pid(tmp_path):
    proc = _hold(tmp_path, 30)
    try:
        with pytest.raises(FolderBusy, match=f"in use by another torchrom run .PID {proc.pid}"):
            with folder_lock(tmp_path, "a test"):
                pass
        assert issubclass(FolderBusy, InputError)  # exit 2 through the CLI
    finally:
        proc.kill()
        proc.wait()
    # the kernel dropped the dead holder's flock: its lock file is stale and taken over
    messages = []
    with folder_lock(tmp_path, "a test", log=messages.append):
        assert read_holder(tmp_path / LOCK_NAME)["pid"] == str(os.getpid())
    assert len(messages) == 1
    assert messages[0].startswith(f"{tmp_path}: recovered a stale lock of PID {proc.pid}")

def test_a_stale_lock_file_of_a_dead_pid_is_recovered(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / LOCK_NAME).write_text(f"pid={dead.pid}\nwhat=a sweep\n")
    messages = []
    with folder_lock(tmp_path, log=messages.append):
        pass
    assert len(messages) == 1 and f"stale lock of PID {dead.pid}" in messages[0]


def test_wait_serialises_behind_the_holder(tmp_path):
    proc = _hold(tmp_path, 1.5)
    messages = []
    t0 = time.monotonic()
    with folder_lock(tmp_path, "building a model", wait=True, log=messages.append):
        waited = time.monotonic() - t0
        assert proc.stdout.readline().strip() == "released"  # the holder had finished
    proc.wait()
    assert waited > 0.5
    assert messages[0].startswith(f"{tmp_path}: waiting for another torchrom run (PID "
                                  f"{proc.pid}") and "to finish building a model" in messages[0]


def test_a_folder_that_is_a_file_is_bad_input(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="is a file, not a folder"):
        with folder_lock(tmp_path / "f" / "out"):
            pass


def test_deferred_interrupt_waits_for_release():
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        pytest.skip("SIGINT is not Python's default handler in this test run")
    with DeferredInterrupt() as guard:
        guard.hold()
        os.kill(os.getpid(), signal.SIGINT)  # recorded, not raised: the work is being stored
        time.sleep(0.01)
        with pytest.raises(KeyboardInterrupt):
            guard.release()
        with pytest.raises(KeyboardInterrupt):  # outside a hold: at once
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1)
        guard.hold()
        os.kill(os.getpid(), signal.SIGINT)
        with pytest.raises(KeyboardInterrupt):  # a second Ctrl-C while held: at once
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


# -- the fallback without flock: exclusive creation, host-aware stale locks --

#: argv: folder, attempts, mode. Takes the lock of the folder ``attempts`` times on the forced
#: fallback (``_try_flock`` says "not supported"); inside, it creates its marker file and counts
#: the markers of the folder's ``inside/``: more than its own is a second holder at the same
#: time, written to ``overlaps/``. Mode "crash": every third hold ends with os._exit inside the
#: lock (its marker removed first): a killed holder's lock file, left for the others to take
#: over. Mode "unsafe": the lock file opened as before this fallback (without O_EXCL, every
#: opener "created" it): the control that shows the count sees two holders when they exist.
CONTENDER = """
import os, random, sys, time
from pathlib import Path
import torchrom.locks as locks
from torchrom.locks import FolderBusy, folder_lock

folder, attempts, mode = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
locks._try_flock = lambda fd: None
if mode == "unsafe":
    locks._open_lock = lambda path: (os.open(path, os.O_RDWR | os.O_CREAT, 0o644), True)
inside, overlaps = folder.parent / "inside", folder.parent / "overlaps"
marker = inside / str(os.getpid())
held = 0
while held < attempts:
    try:
        with folder_lock(folder, "a test", log=lambda msg: None):
            marker.touch()
            others = [p.name for p in inside.iterdir() if p != marker]
            time.sleep(random.uniform(0, 0.004))
            others += [p.name for p in inside.iterdir() if p != marker]
            if others:
                (overlaps / f"{os.getpid()}-{held}").write_text(" ".join(others))
            marker.unlink()
            held += 1
            if mode == "crash" and held % 3 == 0:
                print(held, flush=True)
                os._exit(0)
    except FolderBusy:
        time.sleep(random.uniform(0, 0.003))
print(held, flush=True)
"""


def _contend(tmp_path, processes: int, attempts: int, mode: str) -> tuple[int, list[str]]:
    """(holds completed, overlaps seen) of ``processes`` contenders started together."""
    folder = tmp_path / "out"
    folder.mkdir(parents=True)
    (tmp_path / "inside").mkdir()
    (tmp_path / "overlaps").mkdir()
    procs = [subprocess.Popen([sys.executable, "-c", CONTENDER, str(folder), str(attempts),
                               mode], stdout=subprocess.PIPE, text=True)
             for _ in range(processes)]
    held = 0
    for proc in procs:
        out, _ = proc.communicate(timeout=120)
        assert proc.returncode == 0
        held += int(out.split()[-1])
    return held, sorted(p.read_text() for p in (tmp_path / "overlaps").iterdir())


def test_fallback_two_processes_never_hold_it_at_once(tmp_path):
    """6 processes × 25 holds each on the forced fallback: 150 holds, none beside another. The
    same count with the lock file opened without O_EXCL (the fallback before this one) sees
    overlaps, so the count can tell."""
    held, overlaps = _contend(tmp_path / "safe", 6, 25, "exclusive")
    assert held == 150 and overlaps == []
    held, overlaps = _contend(tmp_path / "unsafe", 6, 25, "unsafe")
    assert held == 150 and overlaps


def test_fallback_killed_holders_locks_are_taken_over_one_at_a_time(tmp_path):
    """Holders that die inside the lock (os._exit; 6 of them) leave their lock files; the live
    contenders take each over (same host, dead PID), under the takeover file, and still never
    two at a time. A stale lock of a dead process is there from the start as well."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    folder = tmp_path / "out"
    for sub in (folder, tmp_path / "inside", tmp_path / "overlaps"):
        sub.mkdir()
    (folder / LOCK_NAME).write_text(f"pid={dead.pid}\nhost={socket.gethostname()}\n")
    procs_held = []
    procs = [subprocess.Popen([sys.executable, "-c", CONTENDER, str(folder), "9", mode],
                              stdout=subprocess.PIPE, text=True)
             for mode in ("crash", "crash", "exclusive", "exclusive")]
    for proc in procs:
        out, _ = proc.communicate(timeout=120)
        assert proc.returncode == 0
        procs_held.append(int(out.split()[-1]))
    assert procs_held == [3, 3, 9, 9]  # crashed after 3 holds; the others finished theirs
    assert list((tmp_path / "overlaps").iterdir()) == []
    assert not (folder / (LOCK_NAME + TAKEOVER_SUFFIX)).exists()


def test_fallback_stale_lock_of_this_host_is_recovered_another_hosts_is_refused(
        tmp_path, monkeypatch):
    monkeypatch.setattr(locks, "_try_flock", lambda fd: None)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    lock = tmp_path / LOCK_NAME
    lock.write_text(f"pid={dead.pid}\nhost={socket.gethostname()}\nwhat=a sweep\n")
    messages = []
    with folder_lock(tmp_path, log=messages.append):
        assert read_holder(lock)["pid"] == str(os.getpid())
    assert messages == [f"{tmp_path}: recovered a stale lock of PID {dead.pid} (no longer "
                        f"running)"]
    assert not lock.exists()
    # the same dead PID recorded by another host: it may be alive there, so never taken over
    lock.write_text(f"pid={dead.pid}\nhost=node17.cluster\ncommand=torchrom sweep a.toml\n")
    with pytest.raises(FolderBusy) as refused:
        with folder_lock(tmp_path, log=messages.append):
            pass
    assert str(refused.value) == (
        f"{tmp_path}: in use by another torchrom run (PID {dead.pid} on node17.cluster, "
        f"`torchrom sweep a.toml`); wait for it to finish, stop it, or choose another folder; "
        f"if that run is no longer running, remove {lock}")
    assert lock.read_text().startswith(f"pid={dead.pid}\nhost=node17.cluster")  # untouched
    # a live process of this host holds it: refused without the hint (its liveness is known)
    lock.write_text(f"pid={os.getppid()}\nhost={socket.gethostname()}\n")
    with pytest.raises(FolderBusy, match=f"PID {os.getppid()}\\);.* another folder$"):
        with folder_lock(tmp_path):
            pass


def test_fallback_waits_for_a_holder_that_releases(tmp_path, monkeypatch):
    """wait=True without flock: the waiter looks again every POLL_S until the file is gone."""
    code = ("import sys, time\nimport torchrom.locks as L\nL._try_flock = lambda fd: None\n"
            + HOLDER.split("\n", 2)[2])
    proc = subprocess.Popen([sys.executable, "-c", code, str(tmp_path), "1.0"],
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "held"
    messages = []
    monkeypatch.setattr(locks, "_try_flock", lambda fd: None)
    with folder_lock(tmp_path, "building a model", wait=True, log=messages.append):
        assert proc.stdout.readline().strip() == "released"
        assert read_holder(tmp_path / LOCK_NAME)["pid"] == str(os.getpid())
    proc.wait()
    assert messages[0].startswith(f"{tmp_path}: waiting for another torchrom run (PID "
                                  f"{proc.pid}")


def test_a_takeover_file_left_by_a_killed_run_is_named(tmp_path, monkeypatch):
    monkeypatch.setattr(locks, "_try_flock", lambda fd: None)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / LOCK_NAME).write_text(f"pid={dead.pid}\nhost={socket.gethostname()}\n")
    guard = tmp_path / (LOCK_NAME + TAKEOVER_SUFFIX)
    guard.write_text(f"pid={dead.pid}\n")
    os.utime(guard, (time.time() - 60, time.time() - 60))
    with pytest.raises(FolderBusy, match=f"{guard}: left by a torchrom run that stopped while "
                                         f"it removed the stale lock of PID {dead.pid}; remove"):
        with folder_lock(tmp_path):
            pass


def test_a_file_system_without_exclusive_creation_is_refused(tmp_path, monkeypatch):
    real_open = os.open

    def no_excl(path, flags, *args):
        if flags & os.O_EXCL:
            raise OSError(errno.EOPNOTSUPP, "Operation not supported", str(path))
        return real_open(path, flags, *args)

    monkeypatch.setattr(os, "open", no_excl)
    with pytest.raises(InputError, match="cannot create a file exclusively .O_EXCL: Operation "
                                         "not supported., so torchrom cannot keep two runs"):
        with folder_lock(tmp_path):
            pass
