"""What this process may use: its memory and its CPUs as the kernel limits them.

The machine's own figures overstate what a process in a container or a batch job gets:

- a cgroup caps its memory (v2 ``memory.max``, v1 ``memory.limit_in_bytes``) and its CPU time
  (v2 ``cpu.max``, v1 ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us``), on its own folder and on
  every folder above it in the hierarchy;
- an affinity mask (``taskset``, Slurm, ``os.sched_getaffinity``) restricts it to some cores.

:func:`available_memory` is the least of the RAM available (psutil, on every platform) and, on
each cgroup level with a memory limit, the limit less the memory charged there that cannot be
reclaimed (usage less inactive page cache, ``inactive_file``: the kubelet's working set).
:func:`usable_cpus` is the cores of the affinity mask, at most the CPU quota rounded up.
Where the cgroup files are absent (macOS, Windows, no cgroup mount) only the machine's figures
count.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

#: v1 writes "no limit" as the largest page-aligned 63-bit value; anything above this is none
_UNLIMITED = 2**60


@dataclass(frozen=True)
class CgroupLimits:
    """Limits of this process's cgroups (None: no limit on any level).

    ``memory_max`` (bytes): the least memory limit of the process's cgroup and its ancestors;
    ``memory_available`` (bytes): the least of limit − working set over those levels;
    ``cpu_quota`` (CPUs, quota / period): the least CPU quota over those levels."""

    memory_max: int | None = None
    memory_available: int | None = None
    cpu_quota: float | None = None


@dataclass(frozen=True)
class CgroupFolder:
    """One hierarchy's folder of this process: ``version`` 1 or 2, the v1 ``controllers``
    mounted there, the process's ``folder`` and the hierarchy's ``mount`` point."""

    version: int
    controllers: frozenset[str]
    folder: Path
    mount: Path


def read_cgroup_limits(proc: str | os.PathLike = "/proc/self") -> CgroupLimits:
    """The limits of the process whose ``/proc/<pid>`` folder is ``proc`` (``cgroup`` and
    ``mountinfo`` read there; the cgroup files where ``mountinfo`` says they are mounted)."""
    proc = Path(proc)
    try:
        membership = (proc / "cgroup").read_text()
        mounts = (proc / "mountinfo").read_text()
    except OSError:  # not Linux, or /proc not mounted
        return CgroupLimits()
    memory_max = memory_available = cpu_quota = None
    for found in cgroup_folders(membership, mounts):
        for level in _levels(found):
            if found.version == 2 or "memory" in found.controllers:
                limit, free = _memory_level(level, found.version)
                if limit is not None:
                    memory_max = limit if memory_max is None else min(memory_max, limit)
                    memory_available = (free if memory_available is None
                                        else min(memory_available, free))
            if found.version == 2 or "cpu" in found.controllers:
                quota = _cpu_level(level, found.version)
                if quota is not None:
                    cpu_quota = quota if cpu_quota is None else min(cpu_quota, quota)
    return CgroupLimits(memory_max, memory_available, cpu_quota)


def cgroup_folders(membership: str, mountinfo: str) -> list[CgroupFolder]:
    """The folders of a process's cgroups from its ``/proc/<pid>/cgroup`` (``membership``:
    ``ID:CONTROLLERS:PATH`` lines, ``0::PATH`` for v2) and ``/proc/<pid>/mountinfo``. A path
    outside the mounted part of the hierarchy, or missing under the mount point (a container
    that sees its own cgroup as the root), resolves to the mount point."""
    mounts = []  # (version, controllers, root, mount point)
    for line in mountinfo.splitlines():
        fields = line.split()
        if "-" not in fields:
            continue
        dash = fields.index("-")
        fstype, options = fields[dash + 1], fields[dash + 3] if len(fields) > dash + 3 else ""
        if fstype in ("cgroup", "cgroup2") and len(fields) > 4:
            mounts.append((2 if fstype == "cgroup2" else 1, frozenset(options.split(",")),
                           _unescape(fields[3]), Path(_unescape(fields[4]))))
    found = []
    for line in membership.splitlines():
        parts = line.strip().split(":", 2)
        if len(parts) != 3:
            continue
        _id, controllers, path = parts
        wanted = frozenset(c for c in controllers.split(",") if c)
        for version, options, root, point in mounts:
            if (version == 2) != (not wanted) or (wanted and not wanted <= options):
                continue
            rel = os.path.relpath(path, root) if _below(path, root) else "."
            folder = point / rel if rel != "." else point
            found.append(CgroupFolder(version, wanted, folder if folder.is_dir() else point,
                                      point))
            break
    return found


def _below(path: str, root: str) -> bool:
    return path == root or root == "/" or path.startswith(root.rstrip("/") + "/")


def _unescape(text: str) -> str:
    """mountinfo's octal escapes (``\\040`` is a space)."""
    return (text.replace("\\040", " ").replace("\\011", "\t").replace("\\012", "\n")
            .replace("\\134", "\\"))


def _levels(found: CgroupFolder) -> list[Path]:
    """The process's folder and each one above it up to the mount point."""
    levels = [found.folder]
    while levels[-1] != found.mount and found.mount in levels[-1].parents:
        levels.append(levels[-1].parent)
    return levels


def _read_int(path: Path) -> int | None:
    """An integer file (None: absent, unreadable, or "max")."""
    try:
        text = path.read_text().split()
    except OSError:
        return None
    return int(text[0]) if text and text[0].lstrip("-").isdigit() else None


def _stat(path: Path, key: str) -> int:
    try:
        for line in path.read_text().splitlines():
            name, _, value = line.partition(" ")
            if name == key and value.strip().isdigit():
                return int(value)
    except OSError:
        pass
    return 0


def _memory_level(folder: Path, version: int) -> tuple[int | None, int]:
    """(limit, limit − working set) of one level; (None, 0) without a limit there."""
    if version == 2:
        limit, usage = _read_int(folder / "memory.max"), _read_int(folder / "memory.current")
        inactive = _stat(folder / "memory.stat", "inactive_file")
    else:
        limit = _read_int(folder / "memory.limit_in_bytes")
        usage = _read_int(folder / "memory.usage_in_bytes")
        inactive = _stat(folder / "memory.stat", "total_inactive_file")
    if limit is None or limit <= 0 or limit >= _UNLIMITED:
        return None, 0
    working_set = max(0, (usage or 0) - inactive)
    return limit, max(0, limit - working_set)


def _cpu_level(folder: Path, version: int) -> float | None:
    """CPUs of one level's quota (None: none there)."""
    if version == 2:
        try:
            quota, _, period = (folder / "cpu.max").read_text().strip().partition(" ")
        except OSError:
            return None
        if not quota.isdigit():  # "max"
            return None
        period_us = int(period) if period.strip().isdigit() else 100_000
        return int(quota) / period_us if period_us > 0 else None
    quota_us = _read_int(folder / "cpu.cfs_quota_us")
    period_us = _read_int(folder / "cpu.cfs_period_us")
    if quota_us is None or quota_us <= 0 or not period_us:  # -1: no quota
        return None
    return quota_us / period_us


def affinity_cpus() -> int:
    """The cores this process may run on: its affinity mask where the platform has one
    (Linux: ``os.sched_getaffinity``; Windows, BSD: psutil), else all of the machine's."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    import psutil

    process = psutil.Process()
    if hasattr(process, "cpu_affinity"):
        return max(1, len(process.cpu_affinity()))
    return os.cpu_count() or 1


def usable_cpus(proc: str | os.PathLike = "/proc/self") -> int:
    """Cores worth one thread or worker process each: :func:`affinity_cpus`, at most the
    cgroup CPU quota rounded up (a quota of 1.5 CPUs keeps two threads busy)."""
    cores = affinity_cpus()
    quota = read_cgroup_limits(proc).cpu_quota
    if quota is not None:
        cores = min(cores, max(1, math.ceil(quota - 1e-9)))
    return cores


def available_memory(proc: str | os.PathLike = "/proc/self") -> int:
    """Bytes of RAM a new allocation may take: psutil's available memory (MemAvailable on
    Linux), at most what the cgroup limits leave (:class:`CgroupLimits`)."""
    import psutil

    free = int(psutil.virtual_memory().available)
    limited = read_cgroup_limits(proc).memory_available
    return free if limited is None else min(free, limited)
