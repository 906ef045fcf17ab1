"""torchrom.limits: memory and CPU limits from fake cgroup trees (v2, v1, a container's view)
against limits computed by hand, the affinity mask of a real process, and the bounds that use
them. Sizes are exact integers: every comparison is exact."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import psutil
import pytest

from torchrom import bounds, limits
from torchrom.errors import InputError
from torchrom.limits import CgroupLimits, cgroup_folders, read_cgroup_limits, usable_cpus

GiB = 2**30


def _files(folder: Path, **files: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name.replace("_", ".", 1)).write_text(text + "\n")


def _proc(tmp_path: Path, cgroup: str, mountinfo: list[str]) -> Path:
    proc = tmp_path / "proc"
    proc.mkdir()
    (proc / "cgroup").write_text(cgroup)
    (proc / "mountinfo").write_text("\n".join(mountinfo) + "\n")
    return proc


def _v2_mount(point: Path, root: str = "/") -> str:
    return (f"30 23 0:26 {root} {point} rw,nosuid,nodev,noexec,relatime shared:4 - cgroup2 "
            f"cgroup2 rw,nsdelegate,memory_recursiveprot")


def _v1_mount(point: Path, controllers: str, root: str = "/") -> str:
    return (f"35 28 0:31 {root} {point} rw,nosuid,nodev,noexec,relatime shared:15 - cgroup "
            f"cgroup rw,{controllers}")


def _v2_tree(tmp_path: Path, slice_current: int) -> Path:
    """/user.slice (8 GiB, no CPU quota) / job.scope (6 GiB, 1.5 CPUs); the root has neither."""
    mount = tmp_path / "sys" / "fs" / "cgroup"
    _files(mount, cgroup_controllers="cpu memory")
    _files(mount / "user.slice", memory_max=str(8 * GiB), memory_current=str(slice_current),
           memory_stat=f"anon 1000\nfile 2000\ninactive_file {GiB}\nactive_file 5",
           cpu_max="max 100000")
    _files(mount / "user.slice" / "job.scope", memory_max=str(6 * GiB),
           memory_current=str(3 * GiB), memory_stat=f"inactive_file {GiB // 2}",
           cpu_max="150000 100000")
    return _proc(tmp_path, "0::/user.slice/job.scope\n", [
        "22 1 8:1 / / rw,relatime shared:1 - ext4 /dev/sda1 rw", _v2_mount(mount)])


def test_v2_the_least_limit_of_the_folder_and_its_ancestors(tmp_path):
    """job.scope: 6 GiB − (3 − 0.5) GiB working set = 3.5 GiB; user.slice: 8 − (5 − 1) = 4 GiB:
    3.5 GiB available, 6 GiB the limit, 150000/100000 = 1.5 CPUs."""
    got = read_cgroup_limits(_v2_tree(tmp_path, 5 * GiB))
    assert got == CgroupLimits(memory_max=6 * GiB, memory_available=7 * GiB // 2,
                               cpu_quota=1.5)


def test_v2_an_ancestor_nearer_its_limit_decides(tmp_path):
    """user.slice holds 7.75 GiB (0.75 GiB is other jobs'), 1 GiB of it inactive cache:
    8 − 6.75 = 1.25 GiB left there, less than job.scope's own 3.5 GiB."""
    got = read_cgroup_limits(_v2_tree(tmp_path, 7 * GiB + 3 * GiB // 4))
    assert got.memory_available == 5 * GiB // 4 and got.memory_max == 6 * GiB


def test_v1_memory_and_cpu_hierarchies(tmp_path):
    """A v1 (or hybrid) machine: memory 2 GiB − (1.5 − 0.25) GiB = 0.75 GiB; the top level's
    "no limit" (the largest page-aligned 63-bit value) and quota −1 count as none; CPU
    250000/100000 = 2.5. The unified v2 hierarchy of a hybrid holds no controller files."""
    memory = tmp_path / "sys" / "fs" / "cgroup" / "memory"
    cpu = tmp_path / "sys" / "fs" / "cgroup" / "cpu,cpuacct"
    unified = tmp_path / "sys" / "fs" / "cgroup" / "unified"
    _files(memory, memory_limit_in_bytes="9223372036854771712",
           memory_usage_in_bytes=str(20 * GiB))
    _files(memory / "docker" / "abc", memory_limit_in_bytes=str(2 * GiB),
           memory_usage_in_bytes=str(3 * GiB // 2),
           memory_stat=f"cache 5\ninactive_file 7\ntotal_inactive_file {GiB // 4}")
    _files(cpu, cpu_cfs_quota_us="-1", cpu_cfs_period_us="100000")
    _files(cpu / "docker" / "abc", cpu_cfs_quota_us="250000", cpu_cfs_period_us="100000")
    _files(unified, cgroup_procs="1")
    proc = _proc(tmp_path, "12:pids:/docker/abc\n5:memory:/docker/abc\n"
                           "3:cpu,cpuacct:/docker/abc\n1:name=systemd:/docker/abc\n0::/docker/abc\n",
                 [_v1_mount(memory, "memory"), _v1_mount(cpu, "cpu,cpuacct"),
                  _v2_mount(unified)])
    assert read_cgroup_limits(proc) == CgroupLimits(2 * GiB, 3 * GiB // 4, 2.5)


def test_a_containers_view_and_a_mount_of_part_of_the_tree(tmp_path):
    """A container sees its own cgroup as the mount point while /proc/self/cgroup names the
    host's path (no such folder): the mount point's files count. A mount of a sub-tree (root
    /kubepods/pod1) strips that root from the process's path. A mount point with a space is
    escaped (\\040) in mountinfo."""
    mount = tmp_path / "sys" / "fs" / "cgroup"
    _files(mount, memory_max=str(GiB), memory_current=str(GiB // 4), cpu_max="max")
    proc = _proc(tmp_path, "0::/system.slice/docker-0123.scope\n", [_v2_mount(mount)])
    assert read_cgroup_limits(proc) == CgroupLimits(GiB, 3 * GiB // 4, None)

    spaced = tmp_path / "cg root"
    _files(spaced / "c1", memory_max=str(3 * GiB), memory_current="0", cpu_max="50000 100000")
    _files(spaced, memory_max=str(4 * GiB), memory_current=str(GiB))
    escaped = str(spaced).replace(" ", "\\040")
    proc2 = tmp_path / "p2"
    proc2.mkdir()
    (proc2 / "cgroup").write_text("0::/kubepods/pod1/c1\n")
    (proc2 / "mountinfo").write_text(
        f"30 23 0:26 /kubepods/pod1 {escaped} rw - cgroup2 cgroup2 rw\n")
    (found,) = cgroup_folders((proc2 / "cgroup").read_text(), (proc2 / "mountinfo").read_text())
    assert found.folder == spaced / "c1" and found.mount == spaced
    # c1: 3 GiB free of 3; the pod: 4 − 1 = 3 GiB: both 3 GiB; CPU 0.5
    assert read_cgroup_limits(proc2) == CgroupLimits(3 * GiB, 3 * GiB, 0.5)


def test_no_cgroup_files_means_no_limits(tmp_path):
    assert read_cgroup_limits(tmp_path / "absent") == CgroupLimits(None, None, None)
    mount = tmp_path / "cg"
    _files(mount / "a", memory_max="max", cpu_max="max 100000")
    proc = _proc(tmp_path, "0::/a\n", [_v2_mount(mount)])
    assert read_cgroup_limits(proc) == CgroupLimits(None, None, None)


def test_usable_cpus_is_the_affinity_at_most_the_quota_rounded_up(tmp_path, monkeypatch):
    proc = _v2_tree(tmp_path, 5 * GiB)  # 1.5 CPUs
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(8)), raising=False)
    assert usable_cpus(proc) == 2
    assert usable_cpus(tmp_path / "absent") == 8
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {3}, raising=False)
    assert usable_cpus(proc) == 1


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="no affinity API (not Linux)")
def test_a_process_pinned_to_one_core_uses_one():
    """The kernel's mask of a real process, set with os.sched_setaffinity before the count."""
    code = ("import os\nos.sched_setaffinity(0, {min(os.sched_getaffinity(0))})\n"
            "from torchrom.limits import usable_cpus\nprint(usable_cpus())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "1"


def test_available_memory_is_the_least_of_the_machine_and_the_cgroup(tmp_path):
    mount = tmp_path / "cg"
    _files(mount, memory_max=str(GiB // 2), memory_current=str(GiB // 8))
    proc = _proc(tmp_path, "0::/\n", [_v2_mount(mount)])
    machine = psutil.virtual_memory().available
    assert machine > GiB // 2  # (else this machine, not the cgroup, would decide)
    assert limits.available_memory(proc) == 3 * GiB // 8
    assert limits.available_memory(tmp_path / "absent") <= psutil.virtual_memory().total


def test_the_bounds_see_the_cgroup_limit(monkeypatch):
    """The memory bound of every command (torchrom.bounds) reads the cgroup: 1 GB left there
    refuses 0.75 GB without --allow-large."""
    monkeypatch.setattr(limits, "read_cgroup_limits",
                        lambda proc="/proc/self": CgroupLimits(2 * 10**9, 10**9, None))
    assert bounds.available_memory() == min(10**9, psutil.virtual_memory().available)
    with pytest.raises(InputError, match="over 50% of the 1 GB available"):
        bounds.check_memory("x", "a tensor", 0.75e9)
    monkeypatch.setattr(limits, "read_cgroup_limits",
                        lambda proc="/proc/self": CgroupLimits(None, None, 1.0))
    with pytest.raises(InputError, match=r"\(1 cores here, at most 4\)"):
        bounds.check_threads("x", 5)
