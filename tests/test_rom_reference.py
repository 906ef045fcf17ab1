"""The deformed state a ROM is expanded about (torchrom.rom.reference): its constant load, its
output offsets, its file form and its checks. The ROM about a state is tested against closed
forms where it is identified (tests/test_identify_condensation.py) and used
(tests/test_trim_reduced.py)."""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.rom import NonlinearROM
from torchrom.rom.reference import (
    ReferenceState,
    from_arrays,
    output_offsets,
    reference_load,
    reference_q,
    to_arrays,
)

Q_REF = np.array([0.3, -0.1])
F_REF = np.array([2.0, 0.5])


def _rom(reference=None):
    return NonlinearROM(np.eye(2), np.diag([4.0, 9.0]), outputs={"tip": [1.0, 2.0]},
                        reference=reference)


def test_reference_load_is_the_steady_load_of_the_reference_less_its_force():
    """−q∞ Q(0) q_ref − f_ref at each dynamic pressure (by hand: exact); None without one."""
    Q0 = np.array([[-1.0, 0.5], [0.2, -0.3]])
    rom = _rom(ReferenceState(Q_REF, F_REF, {"velocity": 1.0}))
    got = reference_load(rom, Q0, [0.0, 2.0])
    np.testing.assert_array_equal(got[0], -F_REF)
    np.testing.assert_allclose(got[1], -2.0 * Q0 @ Q_REF - F_REF, rtol=0, atol=1e-15)
    assert reference_load(_rom(), Q0, [2.0]) is None


def test_output_offsets_are_what_each_output_reads_at_the_reference():
    rom = _rom(ReferenceState(Q_REF, F_REF))
    np.testing.assert_allclose(output_offsets(rom, rom.output_matrix()[1]), [0.3 - 0.2])
    np.testing.assert_array_equal(output_offsets(_rom(), rom.output_matrix()[1]), [0.0])
    np.testing.assert_array_equal(reference_q(_rom()), [0.0, 0.0])


def test_the_file_keeps_the_reference_and_old_files_have_none(tmp_path):
    ref = ReferenceState(Q_REF, F_REF, {"aoa_deg": 5.0, "velocity": 45.0, "density": 1.225})
    _rom(ref).save(tmp_path / "a.npz")
    back = NonlinearROM.load(tmp_path / "a.npz")
    np.testing.assert_array_equal(back.reference.q, Q_REF)
    np.testing.assert_array_equal(back.reference.force, F_REF)
    assert back.reference.condition == ref.condition
    _rom().save(tmp_path / "b.npz")
    assert NonlinearROM.load(tmp_path / "b.npz").reference is None
    assert from_arrays({}, "x") is None and to_arrays(None) == {}
    # the reference is part of the model: another reference, another hash; none, the old one
    assert _rom(ref).content_hash() != _rom().content_hash()
    assert _rom().content_hash() == NonlinearROM(np.eye(2), np.diag([4.0, 9.0]),
                                                 outputs={"tip": [1.0, 2.0]}).content_hash()


def test_bad_references_are_refused():
    with pytest.raises(InputError, match="q has 2 entries, force 3"):
        ReferenceState(Q_REF, [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="must be finite"):
        ReferenceState([np.nan, 0.0], F_REF)
    with pytest.raises(InputError, match="reference: 3 coordinates, the ROM has 2"):
        _rom(ReferenceState([0.0, 0.0, 1.0], [0.0, 0.0, 0.0]))
    broken = {"reference_q": Q_REF, "reference_force": F_REF,
              "reference_condition_json": np.array("{not json")}
    with pytest.raises(InputError, match="f.npz: a broken reference state"):
        from_arrays(broken, "f.npz")
