"""FileCache: files reused while the hash of their inputs is unchanged (torchrom.paper.cache)."""

from __future__ import annotations

import json

import pytest

from torchrom.errors import InputError
from torchrom.io import write_text_atomic
from torchrom.paper.cache import MANIFEST, FileCache


def test_reuse_rebuild_and_force(tmp_path):
    cache = FileCache(tmp_path)
    key = FileCache.key({"stage": "a", "x": 1})
    assert cache.get("a.txt", key) is None
    cache.put("a.txt", key, lambda p: write_text_atomic(p, "one"))
    again = FileCache(tmp_path)  # a new session reads the manifest
    assert again.get("a.txt", key).read_text() == "one" and again.hits == ["a.txt"]
    assert again.get("a.txt", FileCache.key({"stage": "a", "x": 2})) is None  # input changed
    assert FileCache(tmp_path, force=True).get("a.txt", key) is None
    (tmp_path / "a.txt").unlink()
    assert FileCache(tmp_path).get("a.txt", key) is None  # file gone
    assert FileCache.key({"x": 1, "y": 2}) == FileCache.key({"y": 2, "x": 1})
    assert json.loads((tmp_path / MANIFEST).read_text())["files"]["a.txt"]["key"] == key


def test_a_corrupt_manifest_is_reported(tmp_path):
    (tmp_path / MANIFEST).write_text("{not json")
    with pytest.raises(InputError, match="not a torchrom cache manifest"):
        FileCache(tmp_path)


def test_a_change_of_the_package_source_changes_every_key(tmp_path, monkeypatch):
    """The same inputs made by different code get different keys (an element formulation that
    changes keeps the version number and the deck; the cached model must not be reused)."""
    import shutil

    from torchrom.paper import cache as cache_mod

    copy = tmp_path / "torchrom"
    shutil.copytree(cache_mod.PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(cache_mod, "PACKAGE", copy)
    cache_mod.source_fingerprint.cache_clear()
    try:
        before = FileCache.key({"stage": "fe"})
        (copy / "fe" / "elements" / "quad4.py").write_text(
            (copy / "fe" / "elements" / "quad4.py").read_text() + "\n# a changed formulation\n")
        cache_mod.source_fingerprint.cache_clear()
        assert FileCache.key({"stage": "fe"}) != before
        (copy / "fe" / "elements" / "__pycache__").mkdir(exist_ok=True)
        (copy / "fe" / "elements" / "__pycache__" / "x.json").write_text("{}")
        after = FileCache.key({"stage": "fe"})
        cache_mod.source_fingerprint.cache_clear()
        assert FileCache.key({"stage": "fe"}) == after  # byte-code caches do not count
    finally:
        cache_mod.source_fingerprint.cache_clear()


def test_an_edited_file_is_neither_reused_nor_replaced_without_force(tmp_path):
    """Issue 26: a cached table edited by hand (its SHA-256 differs from the manifest's) is an
    error before any work, whether its key still matches or not; --force rebuilds it."""
    key = FileCache.key({"stage": "a"})
    FileCache(tmp_path).put("t.csv", key, lambda p: write_text_atomic(p, "x\n1\n"))
    (tmp_path / "t.csv").write_text("x\n2\n")
    for k in (key, FileCache.key({"stage": "b"})):
        with pytest.raises(InputError, match=r"t.csv: changed since torchrom wrote it .*--force"):
            FileCache(tmp_path).get("t.csv", k)
    assert (tmp_path / "t.csv").read_text() == "x\n2\n"
    assert FileCache(tmp_path, force=True).get("t.csv", key) is None  # rebuilt with --force
