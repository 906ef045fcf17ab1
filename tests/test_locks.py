"""One torchrom run per folder (torchrom.locks): refusal naming the holder's PID, waiting,
stale locks of dead processes, re-entrancy, and the deferred Ctrl-C (torchrom.interrupts)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from torchrom.errors import InputError
from torchrom.interrupts import DeferredInterrupt
from torchrom.locks import LOCK_NAME, FolderBusy, folder_lock, read_holder

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
