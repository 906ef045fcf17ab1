"""aero.npz round trip and its checks (DESIGN file contract)."""

import numpy as np
import pytest

from torchrom.aero.dlm import GAF
from torchrom.aero.files import AeroData, load_aero, save_aero
from torchrom.aero.rfa import fit_minimum_state
from torchrom.aero.theodorsen import TypicalSection
from torchrom.errors import InputError


@pytest.fixture(scope="module")
def data():
    ts = TypicalSection(3.0, -0.2, 0.1, 0.24, 1.0, 10.0, 25.0)
    k = np.r_[0.0, np.geomspace(0.01, 1.0, 12)]
    gaf = GAF(0.5, 3.0, k, ts.gaf(k), kernel="theodorsen")
    return AeroData(gaf, fit_minimum_state(gaf, n_lags=3), {"source": "typical section"})


def test_round_trip(tmp_path, data):
    path = save_aero(data, tmp_path / "aero.npz")
    back = load_aero(path)
    np.testing.assert_array_equal(back.gaf.Q, data.gaf.Q)
    np.testing.assert_array_equal(back.gaf.k, data.gaf.k)
    for name in ("A0", "A1", "A2", "D", "R", "E", "lag_roots"):
        np.testing.assert_array_equal(getattr(back.rfa, name), getattr(data.rfa, name))
    assert back.mach == 0.5 and back.semichord == 3.0 and back.gaf.kernel == "theodorsen"
    assert back.rfa.fit_error == data.rfa.fit_error and back.metadata["source"] == "typical section"
    # contract layout: Q stored (m, m, nk)
    with np.load(path) as z:
        assert z["Q"].shape == (2, 2, len(data.gaf.k))


def test_refuses_to_overwrite_and_reports_bad_files(tmp_path, data):
    path = save_aero(data, tmp_path / "aero.npz")
    with pytest.raises(InputError, match="already exists"):
        save_aero(data, path)
    save_aero(data, path, force=True)
    with pytest.raises(InputError, match="not found"):
        load_aero(tmp_path / "missing.npz")
    (tmp_path / "junk.npz").write_text("not a zip")
    with pytest.raises(InputError, match="not a readable"):
        load_aero(tmp_path / "junk.npz")
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["D"] = arrays["D"][:, :1]
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(InputError, match=r"bad.npz: D: expected shape"):
        load_aero(tmp_path / "bad.npz")
