"""torchrom.io: atomic writes with the permissions of any new file (the umask), no overwrite,
flushed to the disk around the rename (a kill at any moment leaves the old or the new file)."""

import os
import random
import signal
import stat
import subprocess
import sys
import time

import pytest

from torchrom.errors import InputError
from torchrom.io import (
    check_can_write,
    current_umask,
    process_alive,
    write_json_atomic,
    write_text_atomic,
)


@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_written_files_follow_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        assert current_umask() == mask
        a = write_text_atomic(tmp_path / "a.txt", "x")
        b = write_json_atomic(tmp_path / "b.json", {"x": float("nan")})
    finally:
        os.umask(old)
    for p in (a, b):
        assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~mask  # 0644 for the usual 022
    assert b.read_text() == '{\n  "x": null\n}\n'
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary left


def test_existing_output_is_kept_without_force(tmp_path):
    p = write_text_atomic(tmp_path / "a.txt", "x")
    with pytest.raises(InputError, match="already exists; pass --force"):
        check_can_write(p, False)
    assert check_can_write(p, True) == p


# -- durability: flushed before and after the rename; a kill leaves the old or the new file --

@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fsync order checked on Linux")
def test_the_file_is_flushed_before_the_rename_and_the_folder_after(tmp_path, monkeypatch):
    """The order that a power loss needs: fsync(the temporary file) → rename → fsync(folder).
    Each fsync is identified by the inode its descriptor names."""
    events = []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(fd):
        st = os.fstat(fd)
        events.append(("fsync", st.st_ino, stat.S_ISDIR(st.st_mode)))
        real_fsync(fd)

    def replace(src, dst):
        events.append(("replace", os.stat(src).st_ino, False))
        real_replace(src, dst)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    path = write_json_atomic(tmp_path / "table.json", {"speed": [1.0, 2.0]})
    new = path.stat().st_ino
    assert events == [("fsync", new, False), ("replace", new, False),
                      ("fsync", tmp_path.stat().st_ino, True)]


#: argv: path, mode. Writes new content over ``path`` through write_text_atomic; mode "rename"
#: kills the process (SIGKILL: no finally, no buffers flushed) at the rename, after the data
#: was written and flushed; mode "loop" rewrites the file for ever, alternating two contents
#: of 4 MB, until the parent kills it.
WRITER = """
import os, signal, sys
from torchrom.io import write_text_atomic

path, mode = sys.argv[1], sys.argv[2]
new = "n" * 4_000_000
if mode == "rename":
    os.replace = lambda src, dst: os.kill(os.getpid(), signal.SIGKILL)
    write_text_atomic(path, new)
print("looping", flush=True)
i = 0
while True:
    write_text_atomic(path, ("a", "b")[i % 2] * 4_000_000)
    i += 1
"""


def test_a_kill_at_the_rename_leaves_the_old_file_and_the_next_write_cleans_up(tmp_path):
    path = write_text_atomic(tmp_path / "cache.json", "old")
    proc = subprocess.run([sys.executable, "-c", WRITER, str(path), "rename"])
    assert proc.returncode == -signal.SIGKILL
    assert path.read_text() == "old"
    (part,) = [p for p in tmp_path.iterdir() if p.name.startswith(".cache.json.")]
    assert part.stat().st_size == 4_000_000  # complete and flushed, just not renamed
    write_text_atomic(path, "newer")  # a dead writer's temporary file is removed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache.json"]
    assert path.read_text() == "newer"


def test_kills_at_random_moments_leave_the_old_or_the_new_file(tmp_path):
    """SIGKILL at random moments (at least 10, until both contents have been found) of a writer
    that rewrites a 4 MB file without pause: each time the file under the final name is one of
    the two complete contents, never empty or partial."""
    rng = random.Random(47)
    path = write_text_atomic(tmp_path / "table.csv", "a" * 4_000_000)
    seen = set()
    for trial in range(40):
        if trial >= 10 and len(seen) == 2:
            break
        proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path), "loop"],
                                stdout=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "looping"
        time.sleep(rng.uniform(0.0, 0.3))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        text = path.read_text()
        assert len(text) == 4_000_000 and text in ("a" * 4_000_000, "b" * 4_000_000)
        seen.add(text[0])
    assert seen == {"a", "b"}  # the kills fell on both contents


def test_process_alive_tells_a_running_a_zombie_and_a_reaped_process():
    """psutil's view (not os.kill(pid, 0), which on Windows sends CTRL_C_EVENT): a writer
    that exited but is not yet reaped (a zombie) is dead, so its temporary files are stale."""
    import psutil

    assert process_alive(os.getpid()) and process_alive(1)
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    deadline = time.monotonic() + 30
    while psutil.Process(child.pid).status() != psutil.STATUS_ZOMBIE:
        assert time.monotonic() < deadline
        time.sleep(0.01)
    assert not process_alive(child.pid)
    child.wait()
    assert not process_alive(child.pid) and not process_alive(0) and not process_alive(-5)
