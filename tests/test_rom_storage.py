"""rom.npz: exact round trip, and clear errors for corrupt or mismatched files."""

import numpy as np
import pytest
import torch

from torchrom.errors import InputError
from torchrom.rom import NonlinearROM

from .rom_fixtures import random_gram_model


def _rom():
    rom, _, _ = random_gram_model(3, seed=12)
    return rom.replace(
        mode_kinds=["linear", "linear", "dual"],
        outputs={"A_Tz": [0.1, -0.2, 0.0], "q1": [1.0, 0.0, 0.0]},
        metadata={"source": "test", "n_dual": 1},
    )


def test_round_trip_exact(tmp_path):
    rom = _rom()
    path = tmp_path / "rom.npz"
    rom.save(path)
    back = NonlinearROM.load(path)
    for name in NonlinearROM.TENSORS:
        assert torch.equal(getattr(back, name), getattr(rom, name))
    assert back.mode_kinds == rom.mode_kinds
    assert back.metadata == rom.metadata
    assert back.output_matrix()[0] == ["A_Tz", "q1"]
    assert np.array_equal(back.output_matrix()[1], rom.output_matrix()[1])
    assert back.content_hash() == rom.content_hash()
    assert not list(tmp_path.glob(".*part*")), "temporary file left behind"


def test_corrupt_file(tmp_path):
    path = tmp_path / "rom.npz"
    path.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(InputError, match="rom.npz: not a readable rom.npz"):
        NonlinearROM.load(path)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="no such ROM file"):
        NonlinearROM.load(tmp_path / "nope.npz")


def test_missing_arrays_and_wrong_shapes(tmp_path):
    rom = _rom()
    path = tmp_path / "rom.npz"
    rom.save(path)
    with np.load(path) as z:
        data = dict(z)
    bad = dict(data)
    del bad["K3"]
    np.savez(tmp_path / "a.npz", **bad)
    with pytest.raises(InputError, match=r"a.npz: not a torchrom rom.npz: missing arrays \['K3'\]"):
        NonlinearROM.load(tmp_path / "a.npz")
    bad = dict(data, K2=np.zeros((3, 3, 4)))
    np.savez(tmp_path / "b.npz", **bad)
    with pytest.raises(InputError, match=r"b.npz: K2: expected shape"):
        NonlinearROM.load(tmp_path / "b.npz")
    bad = dict(data, format_version=np.array(99))
    np.savez(tmp_path / "c.npz", **bad)
    with pytest.raises(InputError, match="format_version 99 is newer"):
        NonlinearROM.load(tmp_path / "c.npz")


def test_shapes_round_trip_and_old_files_load(tmp_path):
    """Issue 47: the basis on the grids (``shape_*``) is stored with the ROM and read back
    bit for bit; a file without it (written before) loads, and asking it for shapes is an
    InputError in one line naming the file and saying to identify again."""
    from torchrom.rom.shapes import MeshShapes

    rom, _, _ = random_gram_model(3)
    rng = np.random.default_rng(0)
    shapes = MeshShapes([7, 8, 9, 10], rng.normal(size=(4, 3)), rng.normal(size=(4, 6, 3)),
                        quads=[[0, 1, 2, 3]], lines=[[0, 3]], length_unit="m", source="w.bdf")
    rom.replace(shapes=shapes).save(tmp_path / "new.npz")
    back = NonlinearROM.load(tmp_path / "new.npz")
    np.testing.assert_array_equal(back.grid_shapes().phi, shapes.phi)
    np.testing.assert_array_equal(back.shapes.grid_ids, [7, 8, 9, 10])
    assert back.shapes.length_unit == "m"
    assert back.content_hash() == rom.content_hash()  # caches keyed by the model stay valid
    rom.save(tmp_path / "old.npz")
    old = NonlinearROM.load(tmp_path / "old.npz")
    assert old.shapes is None
    with pytest.raises(InputError) as err:
        old.grid_shapes(str(tmp_path / "old.npz"))
    msg = str(err.value)
    assert "\n" not in msg and "old.npz" in msg and "torchrom identify" in msg
    with pytest.raises(InputError, match="2 basis functions on the grids, the ROM has 3"):
        rom.replace(shapes=shapes.with_modes(2))
