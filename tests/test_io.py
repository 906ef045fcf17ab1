"""torchrom.io: atomic writes with the permissions of any new file (the umask), no overwrite."""

import os
import stat

import pytest

from torchrom.errors import InputError
from torchrom.io import check_can_write, current_umask, write_json_atomic, write_text_atomic


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
