"""On-the-fly limit-cycle detection: per-case peak tracking and stop criteria (hand-written).

The integrator records the chosen outputs y = C q and their rates ẏ = C q̇ at every step of a
check interval (a chunk of steps, on the device). At the end of each chunk :class:`PeakTracker`

- finds the extrema of every output as sign changes of ẏ (a maximum where ẏ goes from > 0 to ≤ 0,
  a minimum from < 0 to ≥ 0), refines time and value on the cubic Hermite interpolant of (y, ẏ)
  between the two steps (linear interpolation of ẏ, then one Newton step on the interpolant's
  derivative);
- appends them to a small ring buffer per case and output (the last ``ring`` maxima and minima
  with their times);
- decides, per case, from the half peak-to-peak amplitudes A_j = (max_j − min_j)/2 of the
  decision outputs (j = 0 newest):

  ``lco``       every per-cycle change |A_j − A_{j+1}| ≤ rtol·A_0 over ``cycles`` cycles, and the
                remaining change extrapolated geometrically (Aitken: |δ0| r/(1−r), r = |δ0/δ1|)
                also ≤ rtol·A_0 — so a slowly creeping amplitude is not taken for converged;
  ``decay``     A_0 ≤ decay_ratio · (largest amplitude seen) and falling, or the amplitudes fall
                geometrically over ``cycles`` cycles toward a limit (Aitken) within ± that level
                of zero (a limit far below zero is an unreliable extrapolation of a slow fall,
                e.g. toward an LCO from above);
  ``diverged``  |y| of a decision output above ``max_amplitude``, or the state turned non-finite
                while the amplitude was growing;
  ``failed``    the state turned non-finite otherwise.

Everything here runs on the device with no host synchronisation; the integrator copies the
(B,) status codes to the host once per chunk. Nothing mixes cases.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from ..checks import integer, real
from ..errors import InputError

Tensor = torch.Tensor

# status codes (device) and names (table)
RUNNING, LCO, DECAY, DIVERGED, UNCONVERGED, FAILED = range(6)
STATUS_NAMES = {LCO: "lco", DECAY: "decay", DIVERGED: "diverged", UNCONVERGED: "unconverged",
                FAILED: "failed", RUNNING: "running"}


@dataclass(frozen=True)
class LCOCriteria:
    """Stop criteria of the on-the-fly LCO detection (see the module docstring).

    Attributes:
        rtol: relative amplitude change tolerance (per cycle and extrapolated).
        cycles: number of consecutive cycles over which the change must stay below rtol.
        decay_ratio: a decaying amplitude below this fraction of its largest value is 'decay'.
        max_amplitude: a decision output beyond this magnitude is 'diverged' (output units).
        decision_outputs: indices of the outputs whose amplitude decides (default the first).
        stop: stop cases as soon as they are decided (False: run every case to t_end and
            decide there — the same statuses, used for fixed-length comparisons).
        ring: extrema kept per case, output and kind (≥ cycles + 2).
    """

    rtol: float = 1e-3
    cycles: int = 4
    decay_ratio: float = 1e-2
    max_amplitude: float = math.inf
    decision_outputs: tuple[int, ...] = (0,)
    stop: bool = True
    ring: int = 16

    def __post_init__(self):
        real("lco.rtol", self.rtol)
        integer("lco.cycles", self.cycles)
        real("lco.decay_ratio", self.decay_ratio)
        real("lco.max_amplitude", self.max_amplitude, finite=False)
        integer("lco.ring", self.ring)
        for k in self.decision_outputs:
            integer("lco.decision_outputs", k, minimum=0)
        if not self.rtol > 0:
            raise InputError(f"lco.rtol: expected a positive number, got {self.rtol}")
        if int(self.cycles) < 1:
            raise InputError(f"lco.cycles: expected an integer >= 1, got {self.cycles}")
        if not 0 < self.decay_ratio < 1:
            raise InputError(f"lco.decay_ratio: expected a value in (0, 1), got {self.decay_ratio}")
        if not self.max_amplitude > 0:
            raise InputError(f"lco.max_amplitude: expected a positive number, got "
                             f"{self.max_amplitude}")
        if self.ring < self.cycles + 2:
            raise InputError(f"lco.ring: expected at least cycles + 2 = {self.cycles + 2}, got "
                             f"{self.ring}")
        if not self.decision_outputs:
            raise InputError("lco.decision_outputs: expected at least one output index")


def hermite(y0: Tensor, s0: Tensor, y1: Tensor, s1: Tensor, th: Tensor) -> Tensor:
    """Cubic Hermite interpolant on [0, 1] with end values y0, y1 and end slopes s0, s1 (per unit
    of th, i.e. ẏ·dt)."""
    th2 = th * th
    th3 = th2 * th
    return ((2 * th3 - 3 * th2 + 1) * y0 + (th3 - 2 * th2 + th) * s0
            + (-2 * th3 + 3 * th2) * y1 + (th3 - th2) * s1)


class PeakTracker:
    """Ring buffers of the recent extrema of O outputs for B cases (float64, on the device).

    Attributes (all (B, O, ...) with kind 0 = maxima, 1 = minima):
        values, times: (B, O, 2, ring) extremum values and times (s).
        count: (B, O, 2) number of extrema found so far (slot of the newest = (count−1) % ring).
        y_abs_max: (B, O) largest finite |y| seen.
        amp_max: (B,) largest decision amplitude estimate seen (the reference for 'decay').
    """

    def __init__(self, y0: Tensor, yd0: Tensor, ring: int):
        B, O = y0.shape
        kw = {"device": y0.device, "dtype": torch.float64}
        self.ring = int(ring)
        self.values = torch.zeros(B, O, 2, ring, **kw)
        self.times = torch.zeros(B, O, 2, ring, **kw)
        self.count = torch.zeros(B, O, 2, device=y0.device, dtype=torch.long)
        self.last_y = y0.to(torch.float64)
        self.last_yd = yd0.to(torch.float64)
        finite = torch.isfinite(self.last_y)
        self.y_abs_max = torch.where(finite, self.last_y.abs(), 0.0)
        self.amp_max = torch.zeros(B, **kw)

    @property
    def batch_size(self) -> int:
        return self.values.shape[0]

    def select(self, index: Tensor) -> None:
        """Keep the cases ``index`` (batch compaction)."""
        for name in ("values", "times", "count", "last_y", "last_yd", "y_abs_max", "amp_max"):
            setattr(self, name, getattr(self, name).index_select(0, index))

    # ------------------------------------------------------------------------------------------
    def update(self, Y: Tensor, Yd: Tensor, step0: int | Tensor, dt: float | Tensor) -> None:
        """Add the extrema of a chunk: Y, Yd (N, B, O) at steps step0+1 .. step0+N of a fixed
        step dt; or, with per-case steps (adaptive), ``step0`` the (B,) times at the chunk's
        start and ``dt`` the (B,) steps."""
        N = Y.shape[0]
        per_case = isinstance(dt, Tensor)
        if per_case:
            t_start = step0.to(torch.float64).view(1, -1, 1)
            dt = dt.to(torch.float64).view(1, -1, 1)
        y = torch.cat([self.last_y.unsqueeze(0), Y.to(torch.float64)], dim=0)
        yd = torch.cat([self.last_yd.unsqueeze(0), Yd.to(torch.float64)], dim=0)
        d0, d1 = yd[:-1], yd[1:]
        is_max = (d0 > 0) & (d1 <= 0)
        is_min = (d0 < 0) & (d1 >= 0)
        # the extrema's values and times are computed where there is one (a few per cycle
        # among the N·B·O samples: the chunk's work drops from ~50 passes over all of them;
        # on a GPU one more host synchronisation per chunk, which synchronises for its
        # decisions anyway)
        at = (is_max | is_min).nonzero(as_tuple=True)
        d0, d1 = d0[at], d1[at]
        if per_case:
            t_start, dt = t_start.expand(N, -1, Y.shape[2])[at], dt.expand(N, -1, Y.shape[2])[at]
        th = (d0 / (d0 - d1)).clamp(0.0, 1.0)
        y0, y1, s0, s1 = y[:-1][at], y[1:][at], d0 * dt, d1 * dt
        # one Newton step on the Hermite interpolant's derivative (a quadratic in th) moves the
        # linear-interpolation estimate to the interpolant's own extremum (about twice as
        # accurate; the interpolant itself is off by O(dt (ω dt)²) in time, O((ω dt)⁴) in value)
        th2 = th * th
        dp = (6 * th2 - 6 * th) * (y0 - y1) + (3 * th2 - 4 * th + 1) * s0 + (3 * th2 - 2 * th) * s1
        ddp = (12 * th - 6) * (y0 - y1) + (6 * th - 4) * s0 + (6 * th - 2) * s1
        step = torch.where(ddp != 0, dp / torch.where(ddp != 0, ddp, 1.0), 0.0)
        th = (th - step).clamp(0.0, 1.0)
        steps = at[0].to(torch.float64)
        val = torch.zeros_like(Y, dtype=torch.float64)
        t = torch.zeros_like(val)
        val[at] = hermite(y0, s0, y1, s1, th)
        t[at] = t_start + (steps + th) * dt if per_case else (steps + float(step0) + th) * dt
        self._push(0, is_max, val, t)
        self._push(1, is_min, val, t)
        self.last_y = y[-1]
        self.last_yd = yd[-1]
        absY = torch.where(torch.isfinite(y[1:]), y[1:].abs(), 0.0).amax(0)
        self.y_abs_max = torch.maximum(self.y_abs_max, absY)

    def _push(self, kind: int, mask: Tensor, val: Tensor, t: Tensor) -> None:
        K = self.ring
        cum = mask.to(torch.long).cumsum(0)
        total = cum[-1]
        keep = mask & (total.unsqueeze(0) - cum < K)
        # the K newest extrema of each (case, output) go to distinct ring slots: written at
        # their positions only (no pass over all N·B·O samples)
        n, b, o = keep.nonzero(as_tuple=True)
        slot = (self.count[b, o, kind] + cum[n, b, o] - 1) % K
        self.values[b, o, kind, slot] = val[n, b, o]
        self.times[b, o, kind, slot] = t[n, b, o]
        self.count[:, :, kind] += total

    # ------------------------------------------------------------------------------------------
    def recent(self, outputs, kind: int, j: int) -> tuple[Tensor, Tensor, Tensor]:
        """(value, time, valid) of the j-th newest extremum (j = 0 newest), (B, len(outputs))."""
        outputs = list(outputs)
        count = self.count[:, outputs, kind]
        slot = ((count - 1 - j) % self.ring).unsqueeze(-1)
        v = self.values[:, outputs, kind].gather(-1, slot).squeeze(-1)
        t = self.times[:, outputs, kind].gather(-1, slot).squeeze(-1)
        return v, t, count > j

    def amplitudes(self, outputs, n: int) -> tuple[Tensor, Tensor]:
        """Half peak-to-peak amplitudes A_j, j = 0..n−1 (newest first): (B, D, n) and validity."""
        amps, valid = [], []
        for j in range(n):
            vmax, _, okmax = self.recent(outputs, 0, j)
            vmin, _, okmin = self.recent(outputs, 1, j)
            amps.append(0.5 * (vmax - vmin))
            valid.append(okmax & okmin)
        return torch.stack(amps, -1), torch.stack(valid, -1)

    def decide(self, crit: LCOCriteria, state_finite: Tensor, solver_ok: Tensor,
               final: bool) -> Tensor:
        """(B,) status codes: RUNNING or a final status (see the module docstring).

        ``state_finite``/``solver_ok``: (B,) bool from the integrator. With ``final`` (t_end
        reached; a bool or a (B,) bool tensor of the cases that reached it) those cases get a
        status: the ones not settled become UNCONVERGED.
        """
        c = int(crit.cycles)
        outs = list(crit.decision_outputs)
        A, ok = self.amplitudes(outs, c + 2)  # (B, D, c+2)
        tiny = torch.finfo(torch.float64).tiny
        A0 = A[..., 0]
        delta = A[..., :-1] - A[..., 1:]  # newer minus older, (B, D, c+1)
        scale = A0.abs().clamp_min(tiny)
        have = ok[..., c]  # A_0 .. A_c valid
        small = (delta[..., :c].abs() <= crit.rtol * scale.unsqueeze(-1)).all(-1)
        r = (delta[..., 0].abs() / delta[..., 1].abs().clamp_min(tiny)).clamp(max=0.99)
        remaining = delta[..., 0].abs() * r / (1.0 - r)
        lco = (have & small & (remaining <= crit.rtol * scale) & (A0 > 0)).all(-1)

        seen = torch.where(ok, A, 0.0).amax(-1).amax(-1)
        self.amp_max = torch.maximum(self.amp_max, seen)
        ref = self.amp_max.unsqueeze(-1)
        falling = ok[..., 1] & (delta[..., 0] < 0)
        low = falling & (A0 <= crit.decay_ratio * ref)
        # geometric fall toward a limit below the decay level (two successive Aitken estimates)
        mono = have & (delta[..., :c] < 0).all(-1)
        limits = []
        # two successive estimates where the ring holds them (one with cycles = 1)
        for j in range(min(2, delta.shape[-1] - 1)):
            rj = delta[..., j] / delta[..., j + 1].clamp(max=-tiny)
            rj = torch.where(mono & (rj > 0) & (rj < 1), rj, torch.nan)
            limits.append(A[..., j] + delta[..., j] * rj / (1.0 - rj))
        # |limit|: an amplitude falling slowly toward an LCO (a start above it) has r near 1,
        # where the extrapolated limit is far below zero and meaningless — not a decay
        geometric = mono
        for limit in limits:
            geometric = geometric & (limit.abs() <= crit.decay_ratio * ref)
        decay = (low | geometric).all(-1)

        big = (self.y_abs_max[:, outs] > crit.max_amplitude).any(-1)
        growing = (ok[..., 2] & (delta[..., 0] > 0) & (delta[..., 1] > 0)).any(-1)
        status = torch.full_like(A0[:, 0], RUNNING, dtype=torch.long)
        # precedence (lowest first, later assignments win): lco/decay < unconverged < diverged
        status = torch.where(decay, DECAY, status)
        status = torch.where(lco, LCO, status)
        fin = torch.as_tensor(final, device=status.device).expand_as(status)
        if bool(fin.any()):
            # no extremum ever (a case at rest, or a monotone drift): decided by the final value
            never = self.count[:, outs].sum((-1, -2)) == 0
            last = self.last_y[:, outs].abs()
            at_rest = (last <= crit.decay_ratio * self.y_abs_max[:, outs]).all(-1)
            status = torch.where(fin & (status == RUNNING) & never & at_rest, DECAY, status)
            status = torch.where(fin & (status == RUNNING), UNCONVERGED, status)
        status = torch.where(~solver_ok, UNCONVERGED, status)
        status = torch.where(big, DIVERGED, status)
        status = torch.where(~state_finite, torch.where(growing | big, DIVERGED, FAILED), status)
        if not crit.stop:
            keep_running = ~fin & ((status == LCO) | (status == DECAY))
            status = torch.where(keep_running, RUNNING, status)
        return status
