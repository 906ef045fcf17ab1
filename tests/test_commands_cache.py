"""``torchrom cache info|clear`` and the cache root (torchrom.cache_dir, --cache-dir,
$TORCHROM_CACHE)."""

import json
from pathlib import Path

import pytest

from torchrom import cache_dir
from torchrom.cli import main
from torchrom.paper.cache import FileCache
from torchrom.study.config import goland_cache_folder


@pytest.fixture(autouse=True)
def _default_root(monkeypatch):
    monkeypatch.delenv(cache_dir.ENV, raising=False)
    cache_dir.set_cache_root(None)
    yield
    cache_dir.set_cache_root(None)


def _fill(root: Path) -> None:
    cache = FileCache(root / "goland")
    cache.put("rom.npz", "k1", lambda p: p.write_bytes(b"x" * 1500))
    (root / "mine.txt").write_text("not torchrom's")


def test_root_order_option_then_environment_then_home(tmp_path, monkeypatch):
    assert cache_dir.cache_root() == Path.home() / ".cache" / "torchrom"
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
