"""Natural frequencies about a static equilibrium (Nastran's SOL 106 followed by eigenvalues, or
SOL 400's MODES step): K_T(u) φ = ω² M φ with the co-rotational tangent at the deformed state
u, which carries the geometric stiffness of the internal loads. The aerodynamic stiffness is
not in it (these are the deformed structure's modes, as the references give them); flutter
about the state adds the aerodynamics.

Modes are tracked from the undeformed ones by a one-to-one MAC pairing (mass-weighted), as
the references order theirs ("ordered based on the order of the corresponding structural
modes in undeformed shape").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fe.mac import mac_matrix, pair_by_mac

#: the largest relative eigen-residual accepted for a tangent's modes: the deformed Pazy
#: wing's K_T (rigid arms, 1e-4 drilling) gives 1.0e-6 … 1.6e-6 past a quarter of the span,
#: at the default's 1e-6; a frequency's error is of the order of the residual's square
TANGENT_RESIDUAL_TOL = 1e-5


@dataclass
class TangentModes:
    """``frequencies_hz`` (n,) ascending and mass-normalised ``shapes`` (n_dof, n) about a
    state; with a reference, ``tracked`` (r,) the index of each reference mode's partner and
    ``mac`` (r,) its MAC."""

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    tracked: np.ndarray | None = None
    mac: np.ndarray | None = None

    def tracked_frequencies(self) -> np.ndarray:
        """The frequencies in the reference modes' order (Hz)."""
        return self.frequencies_hz[self.tracked]


def tangent_modes(fe, u: np.ndarray, n: int, reference: np.ndarray | None = None
                  ) -> TangentModes:
    """The lowest ``n`` modes of K_T(u) with the model's mass; ``reference`` (n_dof, r ≤ n)
    shapes to track (e.g. the undeformed modes)."""
    from ..fe.solvers import eigenpairs

    M = fe.mass_matrix()
    vals, vecs = eigenpairs(fe.tangent_stiffness(u), M, int(n), residual_tol=TANGENT_RESIDUAL_TOL)
    freqs = np.sqrt(np.maximum(vals, 0.0)) / (2.0 * np.pi)
    if reference is None:
        return TangentModes(freqs, vecs)
    mac = mac_matrix(np.asarray(reference), vecs, M)
    pairs = pair_by_mac(mac)
    return TangentModes(freqs, vecs, pairs, mac[np.arange(len(pairs)), pairs])
