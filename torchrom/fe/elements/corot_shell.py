"""Closed-form derivatives of the shells' co-rotational map (CQUAD4/CTRIA3 frames, no offsets):
the internal force Bᵀ K_e d and the tangent Bᵀ K_e B + Σ_i s_i ∂²d_i/∂u² (s = K_e d) of
:class:`~.corotational.CorotKernel`, without automatic differentiation (whose per-operation
cost is most of a tangent of a few hundred elements: the TACS wingbox, 30 ms against 2 ms).

The local displacements d (see :mod:`.corotational`) are a short chain of maps, each with short
derivatives, composed here by the chain rule:

- the frame E(x) of the element's nodal positions (3nn coordinates): differences, cross
  products, a projection and unit vectors, each carried with its gradient and Hessian and
  chained by hand (:func:`frame_derivatives`);
- the local translations dt_n = Eᵀ (x_n − x̄) − E⁰ᵀ (X_n − X̄), bilinear in E and x;
- the local rotations ϑ_n = log Q_n with Q_n = Eᵀ exp([θ_n×]) E⁰ = M R̃_n, M = Eᵀ E⁰ (of x)
  and R̃_n = exp([ζ_n×]), ζ_n = E⁰ᵀ θ_n (E⁰ orthogonal; Rodrigues' a(s), b(s), s = ζ·ζ, with
  their s-derivatives); ϑ = f(x) v with p = (x, v), x = (3 − tr Q)/2, v = axial(Q)/2,
  f = φ / sin φ, cos φ = 1 − x, whose Hessian in p has only the entries f'' v and f'.

With weights σ on node n's rotations, Σ_i σ_i ∂²ϑ_i = J_pᵀ H_p J_p + Σ W_ij ∂²Q_ij, W = ∂(σ·ϑ)/∂Q,
and ∂²Q splits into ∂²M R̃ (position-position), ∂M ∂R̃ (position-rotation) and M ∂²R̃
(rotation-rotation): no 3nn + 3 Hessian of a 3 × 3 matrix per node is formed.
"""

from __future__ import annotations

import math
from functools import cache

import torch

#: Below these arguments the scalar factors are their Taylor series, where the closed forms'
#: derivatives lose digits to cancellation (b'' at φ = 1: 8 − 8 cos φ against 4φ⁶ b'' ≈ 0.011,
#: 1e-14 relative; f'' at x = 0.1: 3e-14): ``_EXP_TERMS`` terms in s = φ² (the second
#: derivative's last term 110/23! ≈ 4e-21 at s = 1), ``_LOG_TERMS`` in x = 1 − cos φ (ratio
#: about x/2: the second derivative's last term 1e-17 at x = 0.1).
EXP_SERIES_BELOW = 1.0
LOG_SERIES_BELOW = 0.1
_EXP_TERMS = 11
_LOG_TERMS = 16

_A = [(-1.0) ** k / math.factorial(2 * k + 1) for k in range(_EXP_TERMS)]  # sin φ / φ
_B = [(-1.0) ** k / math.factorial(2 * k + 2) for k in range(_EXP_TERMS)]  # (1 − cos φ)/φ²
_F = [2.0**k * math.factorial(k) ** 2 / math.factorial(2 * k + 1) for k in range(_LOG_TERMS)]


def _series(x: torch.Tensor, *c: list[float]):
    """Σ c_k x^k and its first two x-derivatives, each (len(c), ...): the power series of the
    coefficient lists c evaluated together, as products of the powers of x with the
    coefficients (three products instead of a Horner loop of small operations)."""
    K = len(c[0])
    coef, coef1, coef2 = _series_coefficients(tuple(map(tuple, c)), x.dtype, x.device)
    # x^0 .. x^(K−1) by a running product (one operation; a power with a tensor exponent is
    # ten times dearer)
    powers = torch.cat((torch.ones_like(x)[..., None],
                        x[..., None].expand(*x.shape, K - 1).cumprod(-1)), -1)
    out = (powers @ coef, powers[..., :-1] @ coef1, powers[..., :-2] @ coef2)
    return tuple(t.movedim(-1, 0) for t in out)


@cache
def _series_coefficients(c: tuple, dtype, device):
    """The coefficients (K, q) of :func:`_series`' values and of its first two derivatives."""
    k = torch.arange(len(c[0]), dtype=dtype, device=device)
    coef = torch.tensor(c, dtype=dtype, device=device).T
    return coef, k[1:, None] * coef[1:], (k[2:] * k[1:-1])[:, None] * coef[2:]


def rodrigues_factors(s: torch.Tensor):
    """(a, a', a'', b, b', b'') with a = sin φ/φ, b = (1 − cos φ)/φ², φ² = s, ' = d/ds."""
    small = s < EXP_SERIES_BELOW
    if bool(small.all()):  # the usual case (rotations below a radian): the series alone
        return _exp_series(s)
    ss = torch.where(small, torch.ones_like(s), s)
    p = torch.sqrt(ss)
    sn, cs = torch.sin(p), torch.cos(p)
    omc = 2.0 * torch.sin(0.5 * p) ** 2  # 1 − cos φ without cancellation
    closed = (sn / p, (p * cs - sn) / (2 * p * ss),
              (3 * sn - 3 * p * cs - ss * sn) / (4 * p * ss**2),
              omc / ss, (p * sn - 2 * omc) / (2 * ss**2),
              (ss * cs - 5 * p * sn + 8 * omc) / (4 * ss**3))
    if not bool(small.any()):
        return closed
    return tuple(torch.where(small, a, b) for a, b in zip(_exp_series(s), closed))


def _exp_series(s: torch.Tensor):
    v, d1, d2 = _series(s, _A, _B)
    return v[0], d1[0], d2[0], v[1], d1[1], d2[1]


def log_factor(x: torch.Tensor):
    """(f, f', f'') of f(x) = φ / sin φ, cos φ = 1 − x, 0 ≤ x < 2 (the rotation logarithm's
    factor: ϑ = f · axial(Q)/2)."""
    small = x < LOG_SERIES_BELOW
    if bool(small.all()):
        return tuple(t[0] for t in _series(x, _F))
    xs = torch.where(small, torch.ones_like(x), x)
    phi = torch.acos(1.0 - xs)
    r = torch.sqrt(xs * (2.0 - xs))
    num = r - phi * (1.0 - xs)
    closed = (phi / r, num / r**3, phi / r**3 - 3.0 * num * (1.0 - xs) / r**5)
    return tuple(torch.where(small, a[0], b) for a, b in zip(_series(x, _F), closed))


#: The frames' differences of nodal positions w = Λ x (rows: node weights), of which the frame
#: is a function (:func:`frame_derivatives`): the quad's diagonals G1→G3, G2→G4 and its edge sum
#: (G2 + G3) − (G1 + G4); the triangle's edges G1→G2, G1→G3.
FRAME_DIFFERENCES = {"quad": [[-1, 0, 1, 0], [0, -1, 0, 1], [-1, 1, 1, -1]],
                     "tria": [[-1, 1, 0], [-1, 0, 1]]}

# A vector with its derivatives with respect to the m variables: (v (..., 3), g (..., 3, m),
# h (..., 3, m, m) or None: zero, or first order only). The frame is a chain of four maps of
# such vectors, each differentiated by hand (a cross product, a unit vector, a projection).


def _cross3(a: torch.Tensor, b: torch.Tensor, dim: int) -> torch.Tensor:
    """a × b along the axis ``dim`` (negative), broadcast, written out in products of the
    components (twice as fast as ``torch.linalg.cross`` along an inner axis)."""
    a1, a2, a3 = a.unbind(dim)
    b1, b2, b3 = b.unbind(dim)
    return torch.stack((a2 * b3 - a3 * b2, a3 * b1 - a1 * b3, a1 * b2 - a2 * b1), dim)


def _cross_jet(a, b, second: bool):
    """a × b: ∂ = ∂a × b + a × ∂b, ∂² = ∂²a × b + a × ∂²b + ∂_p a × ∂_q b + ∂_q a × ∂_p b."""
    av, ag, ah = a
    bv, bg, bh = b
    v = _cross3(av, bv, -1)
    g = _cross3(ag, bv[..., None], -2) + _cross3(av[..., None], bg, -2)
    h = None
    if second:
        C = _cross3(ag[..., :, None], bg[..., None, :], -3)
        h = C + C.transpose(-1, -2)
        if ah is not None:
            h = h + _cross3(ah, bv[..., None, None], -3)
        if bh is not None:
            h = h + _cross3(av[..., None, None], bh, -3)
    return v, g, h


def _unit_jet(c, second: bool):
    """e = c/|c|: ∂e = P ∂c / |c| with P = I − e eᵀ, and
    ∂²e_i/∂c_j∂c_k = −(P_ij e_k + P_ik e_j + e_i P_jk)/|c|², chained with ∂c and ∂²c."""
    cv, cg, ch = c
    n = torch.linalg.vector_norm(cv, dim=-1)
    e = cv / n[..., None]
    P = -e[..., :, None] * e[..., None, :]
    P.diagonal(dim1=-2, dim2=-1).add_(1.0)
    Pg = P @ cg  # (..., 3, m)
    inv = (1.0 / n)[..., None, None]
    g = Pg * inv
    h = None
    if second:
        t = (e[..., :, None] * cg).sum(-2)  # eᵀ ∂c (..., m)
        Q = cg.transpose(-1, -2) @ Pg  # ∂cᵀ P ∂c (..., m, m)
        first = Pg[..., :, :, None] * t[..., None, None, :]
        h = -(first + first.transpose(-1, -2) + e[..., :, None, None] * Q[..., None, :, :]) \
            * (inv * inv)[..., None]
        if ch is not None:
            m = cg.shape[-1]
            Ph = P @ ch.reshape(*ch.shape[:-2], m * m)
            h = h + Ph.reshape(*Ph.shape[:-1], m, m) * inv[..., None]
    return e, g, h


def _reject_jet(a, e, second: bool):
    """b = a − e (a·e) (a's part normal to the unit vector e; a linear in the variables, ∂²a
    = 0): with s = a·e, ∂b = ∂a − ∂e s − e ∂s and ∂²b = −(∂²e s + ∂e ∂sᵀ + ∂s ∂eᵀ + e ∂²s),
    ∂s = aᵀ ∂e + eᵀ ∂a, ∂²s = Σ a_i ∂²e_i + ∂aᵀ ∂e + ∂eᵀ ∂a."""
    av, ag, _ = a
    ev, eg, eh = e
    s = (av * ev).sum(-1)
    sg = (av[..., :, None] * eg).sum(-2) + (ev[..., :, None] * ag).sum(-2)
    v = av - ev * s[..., None]
    g = ag - eg * s[..., None, None] - ev[..., :, None] * sg[..., None, :]
    h = None
    if second:
        agt_eg = ag.transpose(-1, -2) @ eg
        sh = (av[..., :, None, None] * eh).sum(-3) + agt_eg + agt_eg.transpose(-1, -2)
        cross = eg[..., :, :, None] * sg[..., None, None, :]
        h = -(eh * s[..., None, None, None] + cross + cross.transpose(-1, -2)
              + ev[..., :, None, None] * sh[..., None, :, :])
    return v, g, h


@cache
def _selections(q: int, dtype, device) -> torch.Tensor:
    """∂w_i/∂w (q, 3, 3q): the difference w_i's derivative, the variables row-major (i, xyz)."""
    return torch.eye(3 * q, dtype=dtype, device=device).reshape(q, 3, 3 * q)


def frame_derivatives(frame: str, w: torch.Tensor, second: bool):
    """E (..., 3, 3), columns e1, e2, e3, of the differences w (..., q, 3)
    (:data:`FRAME_DIFFERENCES`; the "quad" and "tria" frames of
    :func:`~.corotational.element_frame`), its gradient (..., 3, 3, 3q) and, with ``second``,
    its Hessian (..., 3, 3, 3q, 3q) (else None) in the entries of w, row-major."""
    sel = _selections(w.shape[-2], w.dtype, w.device)
    d = [(w[..., i, :], sel[i], None) for i in range(w.shape[-2])]
    if frame == "quad":
        e3 = _unit_jet(_cross_jet(d[0], d[1], second), second)
        e1 = _unit_jet(_reject_jet(d[2], e3, second), second)
    elif frame == "tria":
        e3 = _unit_jet(_cross_jet(d[0], d[1], second), second)
        e1 = _unit_jet(d[0], second)
    else:
        raise ValueError(f"frame: expected 'quad' or 'tria', got {frame!r}")
    e2 = _cross_jet(e3, e1, second)
    cols = (e1, e2, e3)
    E = torch.stack([c[0] for c in cols], -1)
    shape = w.shape[:-2] + (3, w.shape[-2] * 3)
    JE = torch.stack([c[1].expand(shape) for c in cols], -2)
    HE = torch.stack([c[2] for c in cols], -3) if second else None
    return E, JE, HE


@cache
def _rotation_constants(dtype, device):
    """I, S_kjq = −ε_kjq and δ_kq δ_jr + δ_kr δ_jq of :func:`rotation_derivatives`."""
    eye = torch.eye(3, dtype=dtype, device=device)
    pair = eye[:, None, :, None] * eye[None, :, None, :]  # δ_kq δ_jr
    return eye, -_levi_civita(dtype, device), pair + pair.transpose(-1, -2)


def _levi_civita(dtype, device) -> torch.Tensor:
    eps = torch.zeros(3, 3, 3, dtype=dtype, device=device)
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        eps[i, j, k], eps[j, i, k] = 1.0, -1.0
    return eps


def rotation_derivatives(z: torch.Tensor, second: bool):
    """R = exp([z×]) = c I + b z zᵀ + a [z×] (..., 3, 3), ∂R_kj/∂z_q (..., 3, 3, 3) and, with
    ``second``, ∂²R_kj/∂z_q∂z_r (..., 3, 3, 3, 3) (else None), c = 1 − b s, s = z·z:
    ∂R_kj/∂z_q = 2 z_q A_kj + b T_kjq + a S_kjq with A = c' I + b' z zᵀ + a' [z×],
    T_kjq = δ_kq z_j + z_k δ_jq, S_kjq = −ε_kjq (= ∂[z×]_kj/∂z_q), and
    ∂²R_kj/∂z_q∂z_r = 2 δ_qr A_kj + 4 z_q z_r A''_kj + 2 (z_q U_kjr + z_r U_kjq)
    + b (δ_kq δ_jr + δ_kr δ_jq) with A'' = c'' I + b'' z zᵀ + a'' [z×], U = b' T + a' S
    (' = d/ds; c' = −b − s b', c'' = −2b' − s b'')."""
    eye, S, pairs = _rotation_constants(z.dtype, z.device)
    s = (z * z).sum(-1)
    a, a1, a2, b, b1, b2 = (t[..., None, None] for t in rodrigues_factors(s))
    s = s[..., None, None]
    zz = z[..., :, None] * z[..., None, :]
    Z = S @ z[..., None, :, None]  # (..., 3, 3, 1): [z×]_kj
    Z = Z[..., 0]
    R = (1.0 - b * s) * eye + b * zz + a * Z
    A = (-b - s * b1) * eye + b1 * zz + a1 * Z
    T = eye[:, None, :] * z[..., None, :, None] + z[..., :, None, None] * eye[None, :, :]
    dR = 2.0 * A[..., None] * z[..., None, None, :] + b[..., None] * T + a[..., None] * S
    if not second:
        return R, dR, None
    A2 = (-2.0 * b1 - s * b2) * eye + b2 * zz + a2 * Z
    U = b1[..., None] * T + a1[..., None] * S
    zq = z[..., None, None, :, None]
    zr = z[..., None, None, None, :]
    d2R = (2.0 * A[..., None, None] * eye + 4.0 * A2[..., None, None] * zq * zr
           + 2.0 * (zq * U[..., None, :] + zr * U[..., :, None])
           + b[..., None, None] * pairs)
    return R, dR, d2R


def _p_maps(dtype, device):
    """L (4, 9): p = (x, v) = L·Q + (3/2, 0, 0, 0) with x = (3 − tr Q)/2, v = axial(Q)/2, Q
    flattened row-major; and, as (9, 36) linear maps of flattened 3 × 3 matrices, the maps
    R̃ → N_r = L_r R̃ᵀ and M → O_r = Mᵀ L_r (p_r = M : N_r and ∂p_r = ∂M : N_r + O_r : ∂R̃)."""
    opts = dict(dtype=dtype, device=device)
    L = torch.zeros(4, 3, 3, **opts)
    L[0] = -0.5 * torch.eye(3, **opts)
    for r, (i, j) in enumerate(((2, 1), (0, 2), (1, 0)), start=1):
        L[r, i, j], L[r, j, i] = 0.5, -0.5
    eye = torch.eye(3, **opts)
    to_N = torch.einsum("rij,kK->kjriK", L, eye).reshape(9, 36)  # N_riK = L_rij R̃_Kj
    to_O = torch.einsum("rij,kK->ikrKj", L, eye).reshape(9, 36)  # O_rKj = M_iK L_rij
    return L.reshape(4, 9), to_N, to_O


class ShellMap:
    """d(u), B = ∂d/∂u, Bᵀ s and the weighted Hessian Σ_i s_i ∂²d_i/∂u² of one shell family,
    all elements (and leading states) at once; element DOFs (t, θ) per node, node-major.

    ``X`` (E, nn, 3) initial nodal positions, ``E0`` (E, 3, 3) initial frames, ``loc0``
    (E, nn, 3) initial local positions (those of :class:`~.corotational.CorotKernel`)."""

    def __init__(self, frame: str, X: torch.Tensor, E0: torch.Tensor, loc0: torch.Tensor):
        self.frame, self.X, self.E0, self.loc0 = frame, X, E0, loc0
        self.E0T = E0.transpose(-1, -2)
        nn = self.nn = X.shape[1]
        opts = dict(dtype=X.dtype, device=X.device)
        self.eye_nn = torch.eye(nn, **opts)
        self.centre = self.eye_nn - 1.0 / nn  # ∂(x_n − x̄)/∂x_n'
        self.L, self.to_N, self.to_O = _p_maps(**opts)
        self.p0 = torch.tensor([1.5, 0.0, 0.0, 0.0], **opts)
        weights = torch.tensor(FRAME_DIFFERENCES[frame], **opts)  # (q/3, nn)
        self.Lam = torch.kron(weights, torch.eye(3, **opts))  # ∂w/∂x (q, 3nn)

    def parts(self, ue: torch.Tensor, second: bool) -> dict:
        """The map's pieces at ue (P, E, 6nn): d (P, E, 6nn) and the Jacobians of its
        translations (P, E, nn, 3, 3nn: positions) and rotations (P, E, nn, 3, 3nn + 3:
        positions, then the node's own rotation); with ``second``, what
        :meth:`weighted_hessian` needs."""
        P, E = ue.shape[:2]
        nn, m = self.nn, 3 * self.nn
        u = ue.reshape(P, E, nn, 6)
        x = self.X + u[..., :3]
        w = self.Lam[::3, ::3] @ x  # (P, E, q, 3)
        Ev, JEw, HE = frame_derivatives(self.frame, w, second)
        JE = JEw @ self.Lam  # (P, E, 3, 3, m)
        y = x - x.mean(-2, keepdim=True)
        dt = y @ Ev - self.loc0
        # ∂dt_nj/∂x_n'l' = Σ_l y_nl ∂E_lj/∂x_n'l' + (δ_nn' − 1/nn) E_l'j
        Jdt = ((y @ JE.reshape(P, E, 3, 3 * m)).reshape(P, E, nn, 3, m)
               + (self.centre[:, None, :, None] * Ev.transpose(-1, -2)[:, :, None, :, None, :]
                  ).reshape(P, E, nn, 3, m))
        zeta = u[..., 3:] @ self.E0  # ζ = E⁰ᵀ θ (P, E, nn, 3)
        R, JR, HR = rotation_derivatives(zeta, second)  # (P, E, nn, 3, 3, [3, [3]])
        M = Ev.transpose(-1, -2) @ self.E0  # M_ik = E_li E⁰_lk
        JM = (self.E0T @ JE.reshape(P, E, 3, 3 * m)).reshape(P, E, 3, 3, m).transpose(2, 3)
        JM = JM.reshape(P, E, 9, m)  # ∂M_ik = E⁰_lk ∂E_li
        N = (R.reshape(P, E, nn, 9) @ self.to_N).reshape(P, E, nn, 4, 9)
        O = (M.reshape(P, E, 9) @ self.to_O).reshape(P, E, 1, 4, 9)
        p = (N @ M.reshape(P, E, 1, 9, 1))[..., 0] + self.p0  # (P, E, nn, 4)
        Jpx = (N.reshape(P, E, nn * 4, 9) @ JM).reshape(P, E, nn, 4, m)
        Jpt = O @ JR.reshape(P, E, nn, 9, 3) @ self.E0T[:, None]  # ∂ζ/∂θ = E⁰ᵀ
        Jp = torch.cat((Jpx, Jpt), -1)  # (P, E, nn, 4, m + 3)
        f, f1, f2 = log_factor(p[..., 0])
        v = p[..., 1:]
        rot = f[..., None] * v
        Jrot = (f1[..., None, None] * v[..., None] * Jp[..., :1, :]
                + f[..., None, None] * Jp[..., 1:, :])
        out = dict(d=torch.cat((dt, rot), -1).reshape(P, E, 6 * nn), Jdt=Jdt, Jrot=Jrot)
        if second:
            out.update(HE=HE, JE=JE, y=y, JR=JR, HR=HR, M=M, JM=JM, N=N, Jp=Jp, v=v,
                       f=(f, f1, f2))
        return out

    def _matrix(self, tt, tr, rt, rr) -> torch.Tensor:
        """(P, E, 6nn, 6nn) from its translation/rotation blocks (P, E, nn, 3, nn, 3) (row
        node, component, column node, component); rr block-diagonal, (P, E, nn, 3, 3)."""
        P, E, nn = tt.shape[:3]
        out = tt.new_empty(P, E, nn, 2, 3, nn, 2, 3)
        out[:, :, :, 0, :, :, 0] = tt
        out[:, :, :, 0, :, :, 1] = tr
        out[:, :, :, 1, :, :, 0] = rt
        out[:, :, :, 1, :, :, 1] = 0.0
        out[:, :, :, 1, :, :, 1].diagonal(dim1=2, dim2=4).copy_(rr.permute(0, 1, 3, 4, 2))
        return out.reshape(P, E, 6 * nn, 6 * nn)

    def jacobian(self, parts: dict) -> torch.Tensor:
        """B = ∂d/∂u (P, E, 6nn, 6nn)."""
        Jdt, Jrot = parts["Jdt"], parts["Jrot"]
        P, E, nn = Jdt.shape[:3]
        m = 3 * nn
        tt = Jdt.reshape(P, E, nn, 3, nn, 3)
        return self._matrix(tt, torch.zeros_like(tt), Jrot[..., :m].reshape(P, E, nn, 3, nn, 3),
                            Jrot[..., m:])

    def pull(self, parts: dict, s: torch.Tensor) -> torch.Tensor:
        """Bᵀ s (P, E, 6nn) for s (P, E, 6nn) (the internal force with s = K_e d)."""
        Jdt, Jrot = parts["Jdt"], parts["Jrot"]
        P, E, nn = Jdt.shape[:3]
        m = 3 * nn
        s = s.reshape(P, E, nn, 2, 1, 3)
        fx = (s[..., 0, :, :] @ Jdt.reshape(P, E, nn, 3, m)
              + s[..., 1, :, :] @ Jrot[..., :m]).sum(2).reshape(P, E, nn, 3)
        fr = (s[..., 1, :, :] @ Jrot[..., m:])[..., 0, :]
        return torch.cat((fx, fr), -1).reshape(P, E, 6 * nn)

    def weighted_hessian(self, parts: dict, s: torch.Tensor) -> torch.Tensor:
        """Σ_i s_i ∂²d_i/∂u² (P, E, 6nn, 6nn) at the weights s (P, E, 6nn)."""
        P, E = s.shape[:2]
        nn, m = self.nn, 3 * self.nn
        s = s.reshape(P, E, nn, 6)
        tau, sig = s[..., :3], s[..., 3:]
        f, f1, f2 = parts["f"]
        v, Jp, M = parts["v"], parts["Jp"], parts["M"]
        # Σ_i σ_i ∂²ϑ_i/∂p² = [[f'' σ·v, f' σᵀ], [f' σ, 0]] between the Jacobians of p
        sv = (sig * v).sum(-1)
        # = J0 hᵀ + g kᵀ per node, J0 = ∂x, g = σᵀ ∂v, h = f'' σ·v J0 + f' g, k = f' J0
        J0, g = Jp[..., 0, :], (sig[..., None, :] @ Jp[..., 1:, :])[..., 0, :]
        h = (f2 * sv)[..., None] * J0 + f1[..., None] * g
        k = f1[..., None] * J0
        left, right = torch.cat((J0, g), 2), torch.cat((h, k), 2)  # (P, E, 2nn, m + 3)
        first_xx = left[..., :m].transpose(-1, -2) @ right[..., :m]  # summed over the nodes
        first_xr = J0[..., :m, None] * h[..., None, m:] + g[..., :m, None] * k[..., None, m:]
        first_rr = J0[..., m:, None] * h[..., None, m:] + g[..., m:, None] * k[..., None, m:]
        wp = torch.cat(((f1 * sv)[..., None], f[..., None] * sig), -1)  # ∂(σ·ϑ)/∂p
        W = (wp @ self.L).reshape(P, E, nn, 3, 3)  # ∂(σ·ϑ)/∂Q
        # position-position: W R̃ᵀ (= wp·N) against ∂²M = E⁰ against ∂²E; the translations'
        # Σ_n τ_nj y_nl against ∂²E_lj and their cross terms through ∂y
        C = (wp[..., None, :] @ parts["N"]).sum(2).reshape(P, E, 3, 3)  # C_ik
        D = self.E0 @ C.transpose(-1, -2) + parts["y"].transpose(-1, -2) @ tau  # (l, j)
        q = self.Lam.shape[0]
        Gxx = (D.reshape(P, E, 1, 9) @ parts["HE"].reshape(P, E, 9, q * q)).reshape(P, E, q, q)
        Gxx = self.Lam.T @ Gxx @ self.Lam  # the frame's Hessian in w, then in x
        tc = tau - tau.mean(2, keepdim=True)
        # S_(a, nl) = Σ_j ∂E_lj/∂x_a tc_nj
        S = (tc[:, :, None] @ parts["JE"]).permute(0, 1, 4, 3, 2).reshape(P, E, m, m)
        Gxx = Gxx + S + S.transpose(-1, -2) + first_xx
        # position-rotation Σ W_ij ∂M_ik ∂R̃_kj; rotation-rotation (MᵀW)_kj ∂²R̃_kj
        V = (W @ parts["JR"].permute(0, 1, 2, 4, 3, 5).reshape(P, E, nn, 3, 9))
        X = parts["JM"].transpose(-1, -2)[:, :, None] @ V.reshape(P, E, nn, 9, 3)
        Z = ((M.transpose(-1, -2)[:, :, None] @ W).reshape(P, E, nn, 1, 9)
             @ parts["HR"].reshape(P, E, nn, 9, 9)).reshape(P, E, nn, 3, 3)
        Gxr = first_xr + X @ self.E0T[:, None]  # (P, E, nn, m, 3)
        Grr = first_rr + self.E0[:, None] @ Z @ self.E0T[:, None]
        tr = Gxr.reshape(P, E, nn, nn, 3, 3).permute(0, 1, 3, 4, 2, 5)
        return self._matrix(Gxx.reshape(P, E, nn, 3, nn, 3), tr, tr.permute(0, 1, 4, 5, 2, 3),
                            Grr)
