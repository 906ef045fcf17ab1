"""One torchrom run per folder at a time: a lock file held for the run.

Every command that writes into a folder it keeps state in (``sweep --out``, ``paper --out``, a
cached model folder such as ``~/.cache/torchrom/goland``) holds :func:`folder_lock` on it for
the whole run. The lock is ``<folder>/.torchrom.lock``, locked with ``flock`` (Linux, macOS) and
holding the holder's PID, host and command. A second run on the same folder either refuses at
once (:class:`FolderBusy`, an :class:`~torchrom.errors.InputError`: exit 2, one line naming the
holder's PID) or, with ``wait=True`` (cache entries: the second run reuses what the first one
builds), waits for it. The kernel drops an ``flock`` when its process dies, so the lock of a
killed run is stale by construction: the next run takes it and says so. The file is removed
when the lock is released; a run that finds it replaced while it waited locks the new one.
Re-entrant within a process (a command that locks its folder may call an API that does too).
Where ``flock`` is not supported (NFS mounted ``nolock``, some FUSE file systems; Windows, which
has no ``flock``), the lock is the file itself: it is created with ``O_CREAT | O_EXCL``, which
succeeds for one process only, and removed on release. A lock file left by a killed run is taken
over only when its record names this host and a PID that is no longer running there (under a
second exclusive file, ``.torchrom.lock.takeover``, so that two runs never both remove it); a
holder on another host cannot be checked from here, so the refusal names its host and PID and
the file to remove if that run is gone. A file system that cannot create a file exclusively is
refused in one line (use a folder on a local disk). Hand-written.
"""

from __future__ import annotations

import contextlib
import errno
import os
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

from .errors import InputError
from .io import check_folder, process_alive, write_error

try:
    import fcntl
except ImportError:  # Windows: no flock; the lock is exclusive creation (module docstring)
    fcntl = None

LOCK_NAME = ".torchrom.lock"
#: the exclusive file of a run removing a stale lock (fallback without flock)
TAKEOVER_SUFFIX = ".takeover"
#: seconds between two looks at a lock held without flock (wait=True)
POLL_S = 0.2

#: locks this process holds: resolved folder -> [file descriptor, depth]
_held: dict[str, list[int]] = {}
_guard = threading.Lock()


class FolderBusy(InputError):
    """Another live torchrom process holds the folder's lock."""


def lock_path(folder: str | os.PathLike) -> Path:
    return Path(folder) / LOCK_NAME


def read_holder(path: Path) -> dict[str, str]:
    """The holder recorded in a lock file ({} when unreadable): pid, host, command, since."""
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return {}
    fields = dict(line.split("=", 1) for line in text.splitlines() if "=" in line)
    return {k: v.strip() for k, v in fields.items()}


def describe_holder(holder: dict[str, str]) -> str:
    """"PID 123 on host, `torchrom sweep ...` since 12:00:00" (what is known of it)."""
    if not holder.get("pid"):
        return "a process that has not written its PID yet"
    text = f"PID {holder['pid']}"
    if holder.get("host") and holder["host"] != socket.gethostname():
        text += f" on {holder['host']}"
    if holder.get("command"):
        text += f", `{holder['command'][:80]}`"
    if holder.get("since"):
        text += f", since {holder['since']}"
    return text


def stale_here(holder: dict[str, str]) -> bool:
    """Whether a recorded holder is certainly gone: on this host and its PID not running. A
    holder on another host (or of unknown host) may be alive: never stale from here."""
    pid = holder.get("pid", "")
    return (holder.get("host") == socket.gethostname() and pid.isdigit()
            and int(pid) != os.getpid() and not process_alive(int(pid)))


def _remove_hint(path: Path, holder: dict[str, str]) -> str:
    """How to clear a lock whose holder this process cannot check (another host, no record)."""
    if holder.get("host") == socket.gethostname() and holder.get("pid", "").isdigit():
        return ""
    return f"; if that run is no longer running, remove {path}"


def _try_flock(fd: int) -> bool | None:
    """True: locked; False: held by another process; None: flock not supported here."""
    if fcntl is None:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except BlockingIOError:
        return False
    except OSError as exc:
        if exc.errno in (errno.ENOLCK, errno.EOPNOTSUPP, errno.EINVAL):
            return None
        raise


def _same_file(fd: int, path: Path) -> bool:
    """Whether ``path`` still names the file open as ``fd`` (not removed by a releasing run)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return False
    own = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (own.st_dev, own.st_ino)


def _open_lock(path: Path) -> tuple[int | None, bool]:
    """(descriptor, created): the lock file created exclusively, else the existing one opened
    (None: it was removed in between, look again)."""
    try:
        return os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644), True
    except FileExistsError:
        try:
            return os.open(path, os.O_RDWR), False
        except FileNotFoundError:
            return None, False
    except OSError as exc:
        if exc.errno in (errno.EINVAL, errno.EOPNOTSUPP, errno.ENOSYS):
            # the one place a platform or file system is refused: every lock file is created
            # exclusively (with flock or without), and without it two runs could both hold one
            raise InputError(f"{path}: this file system cannot create a file exclusively "
                             f"(O_EXCL: {exc.strerror}), so torchrom cannot keep two runs "
                             f"apart in {path.parent}; use a folder on a local disk") from None
        raise


def _acquire(folder: Path, what: str, wait: bool, log: Callable[[str], None]) -> int:
    path = lock_path(folder)
    announced = False
    while True:
        fd, created = _open_lock(path)
        if fd is None:
            continue
        try:
            got = _try_flock(fd)
            flock = got is not None
            if not flock:  # no flock here: only the process that created the file holds it
                got = created
            holder = read_holder(path)
            if not got:
                holder = _recorded_holder(path, holder)
                if not flock and stale_here(holder):
                    os.close(fd)
                    fd = None
                    _take_over(path, holder, log)
                    continue
                if not wait:
                    raise FolderBusy(
                        f"{folder}: in use by another torchrom run ({describe_holder(holder)});"
                        f" wait for it to finish, stop it, or choose another folder"
                        + _remove_hint(path, holder))
                if not announced:
                    log(f"{folder}: waiting for another torchrom run ({describe_holder(holder)})"
                        f" to finish {what}" + _remove_hint(path, holder))
                    announced = True
                if not flock:
                    os.close(fd)
                    fd = None
                    time.sleep(POLL_S)  # Ctrl-C interrupts it
                    continue
                fcntl.flock(fd, fcntl.LOCK_EX)  # blocks; Ctrl-C interrupts it
            if not _same_file(fd, path):
                os.close(fd)  # the holder released and removed it meanwhile: lock the new one
                continue
            if holder.get("pid") and holder["pid"] != str(os.getpid()) and not announced:
                log(f"{folder}: recovered a stale lock of {describe_holder(holder)} "
                    f"(no longer running)")
            _write_holder(fd, what)
            return fd
        except BaseException:
            if fd is not None:
                os.close(fd)
            raise


def _take_over(path: Path, holder: dict[str, str], log: Callable[[str], None]) -> None:
    """Remove the lock file of a holder that died on this host (fallback without flock), so
    that the next exclusive creation can succeed. Done under ``<lock>.takeover``, itself
    created exclusively: between its check and its removal no other run can remove the lock
    (its holder is dead, the other breakers wait), so a live run's new lock is never removed."""
    guard = path.with_name(path.name + TAKEOVER_SUFFIX)
    try:
        gfd = os.open(guard, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
    except FileExistsError:
        # another run is removing it (microseconds), or was killed doing so: not removed
        # here, since two runs that both did could remove a live run's lock
        try:
            age = time.time() - guard.stat().st_mtime
        except FileNotFoundError:
            return
        if age > 10.0:
            raise FolderBusy(f"{guard}: left by a torchrom run that stopped while it removed "
                             f"the stale lock of {describe_holder(holder)}; remove {guard} "
                             f"and {path}") from None
        time.sleep(0.01)
        return
    try:
        os.write(gfd, f"pid={os.getpid()}\nhost={socket.gethostname()}\n".encode())
        current = read_holder(path)
        if current and stale_here(current):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(path)
            log(f"{path.parent}: recovered a stale lock of {describe_holder(current)} "
                f"(no longer running)")
    finally:
        os.close(gfd)
        os.unlink(guard)


def _recorded_holder(path: Path, holder: dict[str, str]) -> dict[str, str]:
    """The holder, once it has written its PID: it locks the file first, then writes (up to a
    second later on a loaded machine)."""
    deadline = time.monotonic() + 2.0
    while not holder.get("pid") and time.monotonic() < deadline:
        time.sleep(0.02)
        holder = read_holder(path)
    return holder


def _write_holder(fd: int, what: str) -> None:
    argv = list(sys.argv) or [what]
    cli = argv[0].endswith(("torchrom", os.path.join("torchrom", "__main__.py")))
    command = " ".join(["torchrom" if cli else os.path.basename(argv[0]), *argv[1:]])
    text = (f"pid={os.getpid()}\nhost={socket.gethostname()}\n"
            f"command={command.replace(chr(10), ' ')}\nwhat={what}\n"
            f"since={time.strftime('%Y-%m-%d %H:%M:%S')}\n")
    os.ftruncate(fd, 0)
    os.lseek(fd, 0, os.SEEK_SET)  # (os.pwrite: POSIX only)
    os.write(fd, text.encode())


def _release(folder: Path, fd: int) -> None:
    # remove before unlocking: a run that waited on this file sees it gone and locks a new one
    with contextlib.suppress(OSError):
        if _same_file(fd, lock_path(folder)):
            os.unlink(lock_path(folder))
    os.close(fd)


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike, what: str = "its run", *, wait: bool = False,
                log: Callable[[str], None] | None = None) -> Iterator[Path]:
    """Hold the lock of ``folder`` (created if missing) for the block; see the module
    docstring. ``what``: the work the lock protects, for messages; ``wait``: wait for a live
    holder instead of refusing (:class:`FolderBusy`)."""
    folder = Path(folder)
    log = log or (lambda msg: print(msg, file=sys.stderr))
    check_folder(folder, "output")
    created = not folder.exists()  # removed again if the run leaves it empty (refused input)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(folder, exc) from None
    key = str(folder.resolve())
    with _guard:
        entry = _held.get(key)
        if entry is not None:  # this process holds it already
            entry[1] += 1
    if entry is None:
        try:
            entry = [_acquire(folder, what, wait, log), 1]
        except OSError as exc:
            raise write_error(lock_path(folder), exc) from None
        with _guard:
            _held[key] = entry
    try:
        yield folder
    finally:
        with _guard:
            entry[1] -= 1
            last = entry[1] == 0
            if last:
                del _held[key]
        if last:
            _release(folder, entry[0])
            if created:
                with contextlib.suppress(OSError):
                    folder.rmdir()
