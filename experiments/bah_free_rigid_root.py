"""Why the free BAH aircraft's state space has a real positive root (issue 35): the numbers of
docs/guide/bah.md, "The free aircraft's rigid-body root".

Inputs: the deck (``bah_502.bdf``, tests/decks/pynastran_bah_plane with SUBCASE 2 restored),
its 8L0D ROM and its aero file on the MKAERO k <= 1, built as the guide does:

    torchrom identify bah_502.bdf --linear 8 --dual 0 --out rom.npz
    torchrom aero bah_502.bdf --mach 0.2 --modes 8 --kernel parabolic \\
        --k 0.001 0.05 0.1 0.2 0.5 1.0 --out aero.npz
    PYTHONPATH=$PWD python experiments/bah_free_rigid_root.py bah_502.bdf rom.npz aero.npz

Printed (SI, 1.225 kg/m^3, the ROM's two 0 Hz modes recombined into pure plunge h, the null
direction of the steady GAF's rigid columns, and the mass-orthogonal pitch θ about the CG):

1. the deck's mass, CG and pitch inertia (the FE mass matrix on the grids' rigid motions);
2. the kinematic constant c of the plunge column's k -> 0 slope (dQ_h/dp = c Q_θ(0)) and
   h/θ = -c b, which must be the radius of gyration; the neutral point's distance aft of the
   CG (rigid) and the rigid short period (closed form, after the double root s = 0);
3. the flexible static margin (elastic modes condensed statically, K + q Q(0));
4. the real roots of the quasi-steady model Q0 + p Q1 + p² Q2 with the kinematic identity
   imposed exactly (Q2 = 0 as p-k, the RFA's, the DLM's finite difference at the second k);
5. the state space's largest real root with the RFA fitted alone (``before``) and with the
   rigid columns' slope imposed (``now``: the aero file's), α = 1e-3 1/s.
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.linalg as sl

from torchrom.aero.build import _fit
from torchrom.aero.files import load_aero
from torchrom.aero.flutter import ModalStructure, state_space_matrix
from torchrom.fe.bdf_read import read_bdf
from torchrom.fe.model import assemble_mass

RHO = 1.225  # kg/m^3, the deck's AERO RHOREF


def mass_data(deck) -> tuple[float, np.ndarray, float]:
    """(mass kg, CG (3,) m, I_yy about the CG kg m²) from the FE mass matrix of all grids."""
    fe = read_bdf(deck)
    xyz, mass = fe.grid_xyz, assemble_mass(fe.mesh)
    n = len(xyz)

    def motion(pitch_about=None):
        v = np.zeros((n, 6))
        if pitch_about is None:
            v[:, 2] = 1.0  # plunge
        else:
            r = xyz - pitch_about
            v[:, 0], v[:, 2], v[:, 4] = r[:, 2], -r[:, 0], 1.0
        return v.ravel()

    z, ry = motion(), motion(np.zeros(3))
    x = np.zeros(6 * n)
    x[0::6] = 1.0
    m = z @ mass @ z
    cg = np.array([-(z @ mass @ ry) / m, 0.0, (x @ mass @ ry) / m])
    pitch = motion(cg)
    return m, cg, pitch @ mass @ pitch


def rigid_coordinates(q0: np.ndarray) -> np.ndarray:
    """Orthonormal (8, 8) change of the first two coordinates into (plunge, pitch): plunge is
    the null direction of the steady GAF's rigid columns, pitch the other (nose up: Q_θθ's
    sign kept by the lift's)."""
    _, _, vt = np.linalg.svd(q0[:, :2])
    t = np.eye(q0.shape[0])
    t[:2, 0], t[:2, 1] = vt[-1], vt[0]
    return t


def real_roots(M, K, q0, q1, q2, b, V, alpha=0.0):
    """Real roots (1/s) of det(s² (M + q (b/V)² Q2) + s (α M + q (b/V) Q1) + K + q Q0)."""
    q, m = 0.5 * RHO * V * V, len(M)
    z, i = np.zeros((m, m)), np.eye(m)
    lhs = np.block([[z, i], [-(K + q * q0), -(alpha * M + q * b / V * q1)]])
    rhs = np.block([[i, z], [z, M + q * (b / V) ** 2 * q2]])
    s = sl.eigvals(lhs, rhs)
    return np.sort(s[np.abs(s.imag) < 1e-7].real)


def crossing(f, lo, hi, tol=0.1):
    """The speed in [lo, hi] where f changes sign (bisection; None if it does not)."""
    if np.sign(f(lo)) == np.sign(f(hi)):
        return None
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.sign(f(mid)) == np.sign(f(lo)) else (lo, mid)
    return 0.5 * (lo + hi)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("deck")
    ap.add_argument("rom")
    ap.add_argument("aero")
    args = ap.parse_args(argv)
    rom, aero = np.load(args.rom), load_aero(args.aero)
    M, K = rom["M"][:8, :8], rom["K1"][:8, :8]
    gaf, b = aero.gaf, aero.semichord
    k, Q = gaf.k, gaf.Q
    q0 = Q[0].real
    q1 = Q[1].imag / k[1]  # the slope at the lowest k (0.001)
    q2_dlm = -((Q[2] - q0 - 1j * k[2] * q1) / k[2] ** 2).real
    t = rigid_coordinates(q0)
    q0t, q1t, Kt = t.T @ q0 @ t, t.T @ q1 @ t, t.T @ K @ t

    m, cg, iyy = mass_data(args.deck)
    print(f"1. deck: mass {m:.1f} kg, CG x = {cg[0]:.4f} m, z = {cg[2]:.4f} m, "
          f"I_yy(CG) = {iyy:.4e} kg m^2, radius of gyration {np.sqrt(iyy / m):.4f} m")
    c = q1t[1, 0] / q0t[1, 1]
    resid = np.linalg.norm(q1t[:, 0] - c * q0t[:, 1]) / np.linalg.norm(q1t[:, 0])
    arm = -c * b
    margin = q0t[1, 1] / q0t[0, 1] * arm * np.sign(q0t[0, 1])
    print(f"2. kinematic identity: c = {c:.6f} (residual {resid:.1e}), h/theta = -c b = "
          f"{arm:.4f} m; neutral point {abs(margin):.4f} m "
          f"{'aft of' if q0t[1, 1] > 0 else 'ahead of'} the CG")
    for V in (300.0, 420.0):
        q = 0.5 * RHO * V * V
        w2 = q * q0t[1, 1] + q * q * (b / V) ** 2 * (q1t[0, 0] * q1t[1, 1] - q1t[1, 0] * q1t[0, 1])
        s = np.roots([1.0, q * b / V * (q1t[0, 0] + q1t[1, 1]), w2])
        print(f"   rigid short period at {V:g} m/s: s = {s[0]:.4f}, "
              f"{np.sqrt(w2) / 2 / np.pi:.3f} Hz")

    def flexible_margin(V):
        a = Kt + 0.5 * RHO * V * V * q0t
        s = a[:2, :2] - a[:2, 2:] @ np.linalg.solve(a[2:, 2:], a[2:, :2])
        return s[1, 1] / s[0, 1] * arm * np.sign(q0t[0, 1])

    print("3. flexible static margin (m, + aft): " + ", ".join(
        f"{V:g}: {flexible_margin(V):+.3f}" for V in (1.0, 200.0, 300.0, 350.0, 380.0, 420.0))
          + f"; zero at {crossing(flexible_margin, 300.0, 420.0):.1f} m/s")
    exact = q1t.copy()
    exact[:, 0] = c * q0t[:, 1]  # the kinematic identity, exactly
    q1e = t @ exact @ t.T
    rinv = np.linalg.inv(aero.rfa.R)
    q2_rfa = aero.rfa.A2 - aero.rfa.D @ rinv @ rinv @ aero.rfa.E
    for name, q2 in (("p-k (no p^2)", np.zeros_like(q0)), ("RFA Q2", q2_rfa),
                     ("DLM Q2", q2_dlm)):
        def top(V, q2=q2):
            r = real_roots(M, K, q0, q1e, q2, b, V)
            r = r[np.abs(r) > 1e-3]  # the double root at 0 (split ~1e-5 by round-off)
            return r.max() if len(r) else -1.0
        print(f"4. {name}: largest real root " + ", ".join(
            f"{V:g}: {top(V):+.3f}" for V in (380.0, 400.0, 410.0, 420.0, 440.0, 450.0))
              + f"; crosses 0 at {crossing(top, 360.0, 460.0):.1f} m/s")
    st = ModalStructure(M=M, K=K, alpha=1e-3)
    before = _fit(gaf, int(aero.metadata.get("n_lags", 13)), "minimum-state", False,
                  np.ones(aero.n_modes))  # no 0 Hz mode: the fit alone
    for name, rfa in (("before", before), ("now", aero.rfa)):
        def largest(V, rfa=rfa):
            s = np.linalg.eigvals(state_space_matrix(st, rfa, V, RHO))
            return s[np.abs(s.imag) < 1e-9].real.max()
        print(f"5. state space, {name}: " + ", ".join(
            f"{V:g}: {largest(V):.2g}" for V in (100.0, 200.0, 300.0, 350.0, 380.0, 400.0,
                                                  410.0, 420.0, 440.0)))


if __name__ == "__main__":
    main()
