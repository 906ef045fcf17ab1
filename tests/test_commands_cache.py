"""``torchrom cache info|clear`` and the cache root (torchrom.cache_dir, --cache-dir,
$TORCHROM_CACHE, the user cache folder of platformdirs: $XDG_CACHE_HOME on Linux)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from torchrom import cache_dir
from torchrom.cli import main
from torchrom.paper.cache import FileCache
from torchrom.study.config import goland_cache_folder


@pytest.fixture(autouse=True)
def _default_root(monkeypatch):
    monkeypatch.delenv(cache_dir.ENV, raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    cache_dir.set_cache_root(None)
    yield
    cache_dir.set_cache_root(None)


def _fill(root: Path) -> None:
    cache = FileCache(root / "goland")
    cache.put("rom.npz", FileCache.key({"stage": "rom"}), lambda p: p.write_bytes(b"x" * 1500))
    (root / "mine.txt").write_text("not torchrom's")


def test_root_order_option_then_environment_then_home(tmp_path, monkeypatch):
    if sys.platform.startswith("linux"):  # the XDG default, as before platformdirs
        assert cache_dir.cache_root() == Path.home() / ".cache" / "torchrom"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    if sys.platform.startswith("linux"):
        expected = tmp_path / "xdg" / "torchrom" / "goland"
        assert goland_cache_folder({}, tmp_path / "c.toml") == expected
    monkeypatch.setenv(cache_dir.ENV, str(tmp_path / "env"))
    assert goland_cache_folder({}, tmp_path / "c.toml") == tmp_path / "env" / "goland"
    cache_dir.set_cache_root(tmp_path / "opt")
    assert goland_cache_folder({}, tmp_path / "c.toml") == tmp_path / "opt" / "goland"
    # [model] cache names the folder itself, relative to the configuration
    assert goland_cache_folder({"cache": "m"}, tmp_path / "c.toml") == tmp_path / "m"


def test_info_lists_files_and_clear_removes_only_torchrom_folders(tmp_path, capsys):
    root = tmp_path / "root"
    _fill(root)
    js = tmp_path / "info.json"
    assert main(["cache", "info", "--cache-dir", str(root), "--json", str(js)]) == 0
    out = capsys.readouterr().out
    assert f"cache root: {root}" in out and "goland/" in out and "rom.npz" in out
    info = json.loads(js.read_text())
    (folder,) = info["folders"]
    assert folder["name"] == "goland" and folder["files"][0]["bytes"] == 1500
    assert main(["cache", "clear", "--cache-dir", str(root)]) == 0
    out = capsys.readouterr().out
    assert "removed" in out and "mine.txt" in out
    assert not (root / "goland").exists() and (root / "mine.txt").exists()


def test_environment_variable_is_the_root(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(cache_dir.ENV, str(tmp_path))
    assert main(["cache", "info"]) == 0
    assert "empty: nothing cached yet" in capsys.readouterr().out


def _user_folders(root: Path, target: Path) -> None:
    """What `cache clear` must leave: a project with its own cache.json, a torchrom-looking
    folder holding a file its manifest does not list, symbolic links to a folder and a file."""
    (root / "project").mkdir(parents=True)
    (root / "project" / "cache.json").write_text('{"files": {"thesis.tex": {}}}')
    (root / "project" / "thesis.tex").write_text("years of work")
    cache = FileCache(root / "mixed")
    cache.put("rom.npz", FileCache.key({"x": 1}), lambda p: p.write_bytes(b"r"))
    (root / "mixed" / "notes.txt").write_text("mine")
    target.mkdir()
    FileCache(target).put("rom.npz", FileCache.key({"x": 1}), lambda p: p.write_bytes(b"r"))
    (root / "link").symlink_to(target, target_is_directory=True)
    (root / "filelink").symlink_to(target / "rom.npz")


def test_clear_removes_only_what_it_can_prove_and_follows_no_link(tmp_path, capsys):
    """Issue 26: a folder with any `cache.json` was deleted with a user's thesis, and a symbolic
    link aborted the clear with an OSError naming no path."""
    root = tmp_path / "root"
    _fill(root)
    (root / "goland" / ".rom.npz.x1y2.part.npz").write_bytes(b"left by a kill")
    _user_folders(root, tmp_path / "elsewhere")
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    assert main(["cache", "clear", "--cache-dir", str(root), "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before  # nothing
    assert (f"would remove {root / 'goland'}/ (3 files, 1.7 kB): .rom.npz.x1y2.part.npz, "
            f"cache.json, rom.npz") in out
    assert main(["cache", "clear", "--cache-dir", str(root)]) == 0
    out = capsys.readouterr().out
    assert f"removed {root / 'goland'}" in out and not (root / "goland").exists()
    left = out.split("left in")[1]
    for reason in ("project/ (cache.json is not a torchrom cache manifest)",
                   "mixed/ (holds notes.txt, which its cache.json does not list)",
                   "link (a symbolic link, not followed)", "mine.txt"):
        assert reason in left, out
    assert (root / "project" / "thesis.tex").read_text() == "years of work"
    assert (root / "mixed" / "notes.txt").is_file() and (root / "mixed" / "rom.npz").is_file()
    assert (tmp_path / "elsewhere" / "rom.npz").is_file() and (root / "link").is_symlink()


def test_clear_leaves_a_folder_a_running_torchrom_holds(tmp_path, capsys):
    import subprocess
    import sys

    root = tmp_path / "root"
    _fill(root)
    code = ("import sys, time\nfrom torchrom.locks import folder_lock\n"
            "with folder_lock(sys.argv[1], 'building the Goland model'):\n"
            "    print('held', flush=True)\n    time.sleep(30)\n")
    proc = subprocess.Popen([sys.executable, "-c", code, str(root / "goland")],
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        assert main(["cache", "clear", "--cache-dir", str(root)]) == 0
    finally:
        proc.kill()
        proc.wait()
    out = capsys.readouterr().out
    assert f"goland/ (in use by another torchrom run (PID {proc.pid}" in out
    assert (root / "goland" / "rom.npz").is_file()


def _run(env: dict[str, str], code: str, *argv: str) -> str:
    """stdout of a Python process running ``code`` with ``env`` set (HOME, XDG_CACHE_HOME and
    TORCHROM_CACHE removed unless given)."""
    base = {k: v for k, v in os.environ.items()
            if k not in ("HOME", "XDG_CACHE_HOME", cache_dir.ENV)}
    proc = subprocess.run([sys.executable, "-c", code, *argv], env={**base, **env},
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


ROOT = "from torchrom.cache_dir import cache_root\nprint(cache_root())"
CLI = "import sys\nfrom torchrom.cli import main\nsys.exit(main(sys.argv[1:]))"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="XDG folders are Linux's")
def test_a_process_honours_torchrom_cache_then_xdg_cache_home_then_home(tmp_path):
    home, xdg = tmp_path / "home", tmp_path / "xdg"
    env = {"HOME": str(home), "XDG_CACHE_HOME": str(xdg), cache_dir.ENV: str(tmp_path / "mine")}
    assert _run(env, ROOT).strip() == str(tmp_path / "mine")
    del env[cache_dir.ENV]
    assert _run(env, ROOT).strip() == str(xdg / "torchrom")
    del env["XDG_CACHE_HOME"]
    assert _run(env, ROOT).strip() == str(home / ".cache" / "torchrom")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="XDG folders are Linux's")
def test_the_former_default_is_named_while_it_is_no_longer_read(tmp_path, monkeypatch):
    """A cache under ~/.cache/torchrom while XDG_CACHE_HOME points elsewhere: `cache info` (its
    own process) reads the new root and names the old one with the command that deletes it;
    without XDG_CACHE_HOME the old one is the root again, and not named."""
    home, xdg = tmp_path / "home", tmp_path / "xdg"
    old = home / ".cache" / "torchrom"
    _fill(old)
    _fill(xdg / "torchrom")
    out = _run({"HOME": str(home), "XDG_CACHE_HOME": str(xdg)}, CLI, "cache", "info")
    new = xdg / "torchrom"
    assert out.startswith(f"cache root: {new} (--cache-dir, $TORCHROM_CACHE, else {new})\n")
    assert (f"  {old}: the former default cache root, no longer read; `torchrom cache clear "
            f"--cache-dir {old}` deletes the models in it") in out
    assert "  goland/: 1.7 kB in 1 files" in out
    monkeypatch.setenv("HOME", str(home))
    assert cache_dir.legacy_root() is None and cache_dir.cache_root() == old
