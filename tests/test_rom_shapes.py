"""The ROM's shapes on the grids and the motions they make (torchrom.rom.shapes), each against
an independent form: the orbit's instants against the harmonic balance's own synthesis matrix,
a complex mode's phases against its closed-form amplitude and phase, a history's last period
against the sine it samples, and the storage arrays against the object they came from."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchrom.errors import InputError
from torchrom.periodic.fourier import synthesis_matrix
from torchrom.rom.shapes import (
    KEYS,
    MeshShapes,
    history_period,
    normalised_mode,
    orbit_states,
    phase_frames,
)


def _shapes(n=3, G=5, seed=0) -> MeshShapes:
    rng = np.random.default_rng(seed)
    return MeshShapes(np.arange(101, 101 + G), rng.normal(size=(G, 3)), rng.normal(size=(G, 6, n)),
                      quads=[[0, 1, 2, 3]], trias=[[1, 2, 4]], lines=[[3, 4]], length_unit="m",
                      source="deck.bdf")


def test_motion_is_phi_times_q_grid_by_grid():
    """u[g, c] = Σ_j Φ[g, c, j] q_j, written out as a loop (rounding: 1e-15 of the entries)."""
    s = _shapes()
    q = np.array([0.3, -1.2, 0.7])
    u = s.motion(q)
    loop = np.array([[sum(s.phi[g, c, j] * q[j] for j in range(3)) for c in range(6)]
                     for g in range(s.n_grid)])
    np.testing.assert_allclose(u, loop, rtol=0, atol=1e-14)
    assert s.motion(np.stack([q, 2 * q])).shape == (2, s.n_grid, 6)
    with pytest.raises(InputError, match="expected 3 modal coordinates"):
        s.motion(np.ones(4))


def test_orbit_states_equal_the_harmonic_balance_synthesis():
    """q(t_k) from X (rows a0, a1, b1, a2, b2, ...) equals the HB's own synthesis matrix at
    τ_k = 2πk/N (torchrom.periodic.fourier, the transform the orbit was solved with):
    rounding only (1e-13)."""
    rng = np.random.default_rng(1)
    H, n, N = 4, 3, 16
    X = rng.normal(size=(2 * H + 1, n))
    omega = 2 * np.pi * 1.7
    t, q = orbit_states(X, omega, N)
    S = synthesis_matrix(H, N, dtype=torch.float64).numpy()  # (N, 2H+1)
    np.testing.assert_allclose(q, S @ X, rtol=0, atol=1e-13)
    np.testing.assert_allclose(t, np.arange(N) / N / 1.7, rtol=1e-14)
    # and a closed form: a0 + a1 cos ωt + b2 sin 2ωt
    X = np.zeros((5, 1))
    X[0], X[1], X[4] = 0.5, 2.0, -1.0
    t, q = orbit_states(X, omega, 7)
    np.testing.assert_allclose(q[:, 0], 0.5 + 2 * np.cos(omega * t) - np.sin(2 * omega * t),
                               atol=1e-14)
    with pytest.raises(InputError, match="positive angular frequency"):
        orbit_states(X, 0.0, 7)
    with pytest.raises(InputError, match=r"\(2H\+1, n\)"):
        orbit_states(np.zeros((4, 1)), 1.0, 7)


def test_phase_frames_of_a_complex_mode():
    """Re(u e^{iφ}): φ = 0 is Re u, φ = 90° is −Im u, and over a fine cycle each entry's
    largest value is |u| (closed form; the sampling misses the peak by at most
    |u| (1 − cos(π/N)) = 1.9e-6 |u| at N = 1600)."""
    rng = np.random.default_rng(2)
    u = rng.normal(size=(4, 6)) + 1j * rng.normal(size=(4, 6))
    phi, f = phase_frames(u, 4)
    np.testing.assert_allclose(phi, [0, 90, 180, 270])
    np.testing.assert_allclose(f[0], u.real, atol=1e-15)
    np.testing.assert_allclose(f[1], -u.imag, atol=1e-15)
    _, fine = phase_frames(u, 1600)
    np.testing.assert_allclose(fine.max(axis=0), np.abs(u), rtol=2e-6)


def test_normalised_mode_has_its_largest_translation_one():
    """Scaled so that the grid translation of largest modulus is 1 + 0i (rotations, whose
    unit differs, never set the scale)."""
    s = _shapes()
    v = np.array([1 + 2j, -0.5j, 0.3])
    w = normalised_mode(v, s)
    u = s.motion(w)[..., :3]
    k = np.unravel_index(np.argmax(np.abs(u)), u.shape)
    assert u[k] == pytest.approx(1.0 + 0j, abs=1e-14)
    assert np.abs(u).max() == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(w / w[0], v / v[0], rtol=1e-14)  # the same mode


def test_history_period_is_the_last_period_of_the_samples():
    """A history of q = (sin ωt, 2 cos ωt) sampled at dt: the last period at N instants
    equals the sines there, to linear interpolation's error (ω dt)²/8 · amplitude = 3.1e-5
    at 200 samples a period."""
    f = 2.5
    w = 2 * np.pi * f
    t = np.arange(0, 4.0, 1 / (200 * f))
    q = np.column_stack([np.sin(w * t), 2 * np.cos(w * t)])
    ts, qs = history_period(t, q, f, 10)
    t_abs = ts + t[-1] - 1 / f
    np.testing.assert_allclose(ts, np.arange(10) / (10 * f), atol=1e-12)
    np.testing.assert_allclose(qs[:, 0], np.sin(w * t_abs), atol=3.1e-5)
    np.testing.assert_allclose(qs[:, 1], 2 * np.cos(w * t_abs), atol=6.2e-5)
    with pytest.raises(InputError, match="shorter than one period"):
        history_period(t[:50], q[:50], f, 10)
    with pytest.raises(InputError, match="no period"):
        history_period(t, q, float("nan"), 10)


def test_arrays_round_trip_and_incomplete_arrays_are_refused():
    s = _shapes()
    arrays = s.to_arrays()
    assert set(arrays) == set(KEYS)
    back = MeshShapes.from_arrays(arrays, "rom.npz")
    for name in ("grid_ids", "xyz", "phi", "quads", "trias", "lines"):
        np.testing.assert_array_equal(getattr(back, name), getattr(s, name))
    assert (back.length_unit, back.source) == ("m", "deck.bdf")
    assert MeshShapes.from_arrays({"M": np.eye(2)}, "old.npz") is None
    with pytest.raises(InputError, match="old.npz: incomplete mode shapes"):
        MeshShapes.from_arrays({k: v for k, v in arrays.items() if k != "shape_phi"}, "old.npz")
    with pytest.raises(InputError, match="grid rows outside"):
        MeshShapes(s.grid_ids, s.xyz, s.phi, quads=[[0, 1, 2, 9]])
