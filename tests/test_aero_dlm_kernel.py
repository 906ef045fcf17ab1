"""The torch vortex/doublet-lattice AICs against PanelAero (the reference implementation).

Both implement the same published method (Albano & Rodden 1969; Rodden et al. 1971, 1998;
Katz & Plotkin horseshoes) with the same branches, so they agree to rounding: the bound used
here, 1e-10 relative to the largest entry, leaves ~10⁴ of margin over the ~1e-14 observed
(the quartic fit's fourth differences amplify rounding by (y/e)⁴ on far boxes).
"""

import copy

import numpy as np
import pytest

from torchrom.aero.dlm import BoxMotion, compute_gaf, xz_fold
from torchrom.aero.dlm_kernel import LatticeGeometry, oscillatory_aic, steady_aic
from torchrom.aero.nastran_flutter import load_deck
from torchrom.aero.panels import goland_panels, rectangular_wing
from torchrom.errors import InputError

DECKS = {
    "pt145": "tests/decks/pynastran_pt145/pt145.bdf",
    "bah_plane": "tests/decks/pynastran_bah_plane/bah_plane.bdf",
}
REL = 1e-10


def _panels(name):
    if name == "goland":
        return goland_panels(n_chord=4, n_span=10)  # the built-in planform, coarser
    return load_deck(DECKS[name], require_flutter=False).aero_panels


def _rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


@pytest.fixture(scope="module", params=["goland", "pt145", "bah_plane"])
def panels(request):
    return _panels(request.param)


@pytest.mark.parametrize("mach", [0.0, 0.45])
def test_steady_aic_matches_panelaero_vlm(panels, mach):
    from panelaero import VLM

    ref, _ = VLM.calc_Ajj(copy.deepcopy(panels.to_panelaero()), mach)
    assert _rel(steady_aic(LatticeGeometry.from_panels(panels), mach), ref) < REL


@pytest.mark.parametrize("kernel", ["quartic", "parabolic"])
@pytest.mark.parametrize("mach", [0.0, 0.45])
def test_oscillatory_aic_matches_panelaero_dlm(panels, kernel, mach):
    """Several k in one call (vectorised over k) against PanelAero one k at a time."""
    from panelaero import DLM

    k_pa = [0.03, 1.2]
    chunks = list(oscillatory_aic(LatticeGeometry.from_panels(panels), mach, k_pa, kernel))
    d = np.concatenate([c for _, c in chunks])
    assert np.concatenate([i for i, _ in chunks]).tolist() == [0, 1]
    for i, k in enumerate(k_pa):
        ref = DLM.calc_Ajj(copy.deepcopy(panels.to_panelaero()), mach, k, method=kernel)
        assert np.isfinite(d[i]).all()
        assert _rel(d[i], ref) < REL, (kernel, mach, k)


def test_bah_plane_has_nonplanar_pairs():
    """bah_plane (wing + tail at another height) exercises the nonplanar kernel (P2, D2)."""
    from torchrom.aero.dlm_kernel import _pair_geometry

    geom = LatticeGeometry.from_panels(_panels("bah_plane"))
    assert _pair_geometry(geom, slice(None)).nonplanar
    assert not _pair_geometry(LatticeGeometry.from_panels(_panels("goland")),
                              slice(None)).nonplanar


def _modes(panels, n=3):
    """Smooth symmetric test motions (plunge, pitch, bending) on the boxes of ``panels``."""
    shapes = [
        (lambda x, y: np.ones_like(x), lambda x, y: np.zeros_like(x)),
        (lambda x, y: -(x - 1.0), lambda x, y: -np.ones_like(x)),
        (lambda x, y: (y / 10.0) ** 2 * (1 + 0.1 * x), lambda x, y: 0.1 * (y / 10.0) ** 2),
    ][:n]
    return BoxMotion.from_function(panels, shapes)


@pytest.mark.parametrize("kernel", ["quartic", "parabolic"])
@pytest.mark.parametrize("name,mach", [("goland", 0.0), ("goland", 0.7), ("bah_plane", 0.0),
                                       ("pt145", 0.45)])
def test_gaf_torch_matches_panelaero(name, mach, kernel):
    """The whole GAF (AIC, solve, integration) with both engines; k = 0 included."""
    panels = _panels(name)
    motion = _modes(panels)
    k = [0.0, 0.05, 0.4]
    q_t = compute_gaf(panels, motion, mach, k, 1.5, kernel).Q
    q_p = compute_gaf(panels, motion, mach, k, 1.5, kernel, engine="panelaero").Q
    assert _rel(q_t, q_p) < REL


def test_xz_fold_is_used_and_exact():
    """A mirrored wing with a symmetric motion solves the half model; an asymmetric motion
    (image boxes not following their sources) falls back to the full system."""
    wing = rectangular_wing(2.0, 6.0, 4, 8)
    motion = _modes(wing)
    fold = xz_fold(wing, motion)
    assert fold is not None and fold.sign == 1.0 and len(fold.rows) == wing.n // 2
    real = np.flatnonzero(~wing.mirrored)
    half = real[np.argsort(wing.source[real])]  # the half-model box of each source index
    anti = BoxMotion(*(wing.box_motion(a[:, half], antisymmetric=True)
                       for a in (motion.h_load, motion.h_control, motion.slope_control)))
    assert xz_fold(wing, anti).sign == -1.0
    lopsided = BoxMotion(motion.h_load * (1 + wing.mirrored), motion.h_control,
                         motion.slope_control)
    assert xz_fold(wing, lopsided) is None
    for m in (motion, anti, lopsided):
        q_t = compute_gaf(wing, m, 0.5, [0.0, 0.3], 1.0).Q
        q_p = compute_gaf(wing, m, 0.5, [0.0, 0.3], 1.0, engine="panelaero").Q
        assert _rel(q_t, q_p) < REL


def test_bad_kernel_input():
    geom = LatticeGeometry.from_panels(rectangular_wing(1.0, 2.0, 2, 2))
    with pytest.raises(InputError, match="kernel"):
        list(oscillatory_aic(geom, 0.3, [0.1], "cubic"))
    with pytest.raises(InputError, match="> 0"):
        list(oscillatory_aic(geom, 0.3, [0.0], "quartic"))
    wing = rectangular_wing(1.0, 2.0, 2, 2)
    with pytest.raises(InputError, match="engine"):
        compute_gaf(wing, _modes(wing), 0.3, [0.1], 1.0, engine="fortran")


def test_exact_k_indices_and_interpolated_gaf():
    """k_exact: the ends, k = 0 and an even spread are solved; Q elsewhere from a cubic spline,
    exact at the solved k. Its error (max |ΔQ| / max |Q|) on a plunge/pitch/bending GAF with 24
    k from 0 to 2 (a step ratio of 1.4) solved at 10: observed 2.1e-2, at 14: 9.2e-3 — bound
    5e-2 and decreasing with more solved k (a spline, not a fit)."""
    from torchrom.aero.dlm import exact_k_indices

    k = np.r_[0.0, np.geomspace(1e-3, 2.0, 23)]
    idx = exact_k_indices(k, 10)
    assert len(idx) == 10 and idx[0] == 0 and idx[-1] == len(k) - 1
    assert exact_k_indices(k, None).tolist() == list(range(len(k)))
    shuffled = k[::-1].copy()
    assert set(shuffled[exact_k_indices(shuffled, 10)]) == set(k[idx])
    wing = rectangular_wing(2.0, 6.0, 4, 8)
    full = compute_gaf(wing, _modes(wing), 0.5, k, 1.0).Q
    part = compute_gaf(wing, _modes(wing), 0.5, k, 1.0, k_exact=10).Q
    assert np.array_equal(part[idx], full[idx])
    err = np.abs(part - full).max() / np.abs(full).max()
    finer = compute_gaf(wing, _modes(wing), 0.5, k, 1.0, k_exact=14).Q
    assert 0 < np.abs(finer - full).max() / np.abs(full).max() < err < 5e-2
    with pytest.raises(InputError, match="k_exact"):
        compute_gaf(wing, _modes(wing), 0.5, k, 1.0, k_exact=3)


@pytest.mark.slow
def test_compiled_kernel_matches_eager():
    """The torch.compile'd kernel (used for large lattices) computes the same AICs as the eager
    one (slow: compiling takes 0.5–4 min on 2 shared cores); bah_plane exercises the nonplanar
    graph too."""
    geom = LatticeGeometry.from_panels(_panels("bah_plane"))
    for kernel in ("quartic", "parabolic"):
        k_pa = [0.03, 0.4, 1.2]
        fast = np.concatenate([d for _, d in oscillatory_aic(geom, 0.45, k_pa, kernel, True)])
        slow = np.concatenate([d for _, d in oscillatory_aic(geom, 0.45, k_pa, kernel, False)])
        assert _rel(fast, slow) < REL
