"""On-the-fly peak tracking and the per-case stop decisions, on signals with known extrema."""

import math

import numpy as np
import torch

from torchrom.sim.lco import (
    DECAY,
    DIVERGED,
    FAILED,
    LCO,
    RUNNING,
    UNCONVERGED,
    LCOCriteria,
    PeakTracker,
)

W = 2 * math.pi
DT = 0.005


def _feed(signals, t_end, chunk_sizes=(137, 400, 251)):
    """Run a tracker over signals [(y(t), ẏ(t)) per case] sampled at DT, in uneven chunks."""
    steps = int(round(t_end / DT))
    t = np.arange(steps + 1) * DT
    Y = np.stack([s[0](t) for s in signals], axis=1)[:, :, None]  # (T+1, B, 1)
    Yd = np.stack([s[1](t) for s in signals], axis=1)[:, :, None]
    tr = PeakTracker(torch.tensor(Y[0]), torch.tensor(Yd[0]), ring=16)
    k, i = 0, 0
    while k < steps:
        n = min(chunk_sizes[i % len(chunk_sizes)], steps - k)
        tr.update(torch.tensor(Y[k + 1:k + 1 + n]), torch.tensor(Yd[k + 1:k + 1 + n]), k, DT)
        k += n
        i += 1
    return tr


def _cosine(amp, rate=0.0, omega=W, phase=0.3):
    """A e^{rate t} cos(ω t + φ) and its derivative."""
    def y(t):
        return amp * np.exp(rate * t) * np.cos(omega * t + phase)

    def yd(t):
        return amp * np.exp(rate * t) * (rate * np.cos(omega * t + phase)
                                         - omega * np.sin(omega * t + phase))
    return y, yd


def test_extrema_values_times_and_ring_order_across_chunks():
    tr = _feed([_cosine(1.5)], t_end=20.0)
    count = tr.count[0, 0].tolist()
    assert count == [20, 20]  # one maximum and one minimum per period over 20 periods
    for j in range(16):  # the ring holds the 16 newest, newest first via recent()
        vmax, tmax, ok = tr.recent([0], 0, j)
        assert ok.item()
        # exact maxima: ω t + φ = 2π k; Hermite refinement: value error ≈ (ω dt)⁴/384 ~ 2e-9,
        # time error O(dt (ω dt)²) ~ 1e-7 s
        k = round((W * tmax.item() + 0.3) / (2 * math.pi))
        assert abs(tmax.item() - (2 * math.pi * k - 0.3) / W) < 1e-6
        assert abs(vmax.item() - 1.5) < 1e-8
        assert k == 20 - j
    vmin, tmin, _ = tr.recent([0], 1, 0)
    assert abs(vmin.item() + 1.5) < 1e-8


def test_ring_keeps_the_newest_extrema_of_a_chunk_holding_more_than_it():
    """A chunk with more extrema of a case than the ring holds keeps the newest, in order, per
    case (the extrema are written at their own positions only)."""
    t = np.arange(801) * DT
    signals = [_cosine(1.0, omega=3 * W), _cosine(2.0, omega=5 * W)]
    Y = torch.tensor(np.stack([s[0](t) for s in signals], axis=1)[:, :, None])
    Yd = torch.tensor(np.stack([s[1](t) for s in signals], axis=1)[:, :, None])
    tr = PeakTracker(Y[0], Yd[0], ring=4)
    tr.update(Y[1:401], Yd[1:401], 0, DT)
    tr.update(Y[401:], Yd[401:], 400, DT)
    assert tr.count[:, 0, 0].tolist() == [12, 20]  # 3 and 5 maxima per second over 4 s
    for c, (amp, omega) in enumerate([(1.0, 3 * W), (2.0, 5 * W)]):
        v, tm, ok = zip(*(tr.recent([0], 0, j) for j in range(4)))
        assert all(o[c].item() for o in ok)
        times = [x[c, 0].item() for x in tm]
        # the newest four maxima, newest first: ω t + 0.3 = 2π k for the last four k
        k_last = math.floor((omega * 4.0 + 0.3) / (2 * math.pi))
        expected = [(2 * math.pi * (k_last - j) - 0.3) / omega for j in range(4)]
        assert np.allclose(times, expected, atol=1e-6)
        assert np.allclose([x[c, 0].item() for x in v], amp, atol=1e-6)


def test_decisions_per_case():
    crit = LCOCriteria(rtol=1e-4, cycles=4, decay_ratio=1e-2, max_amplitude=10.0)

    def creeping(t):  # amplitude 1 + 0.5 e^{-0.01 t}: per-cycle change 5e-3·… but far from done
        return (1 + 0.5 * np.exp(-0.01 * t)) * np.cos(W * t)

    def creeping_d(t):
        a = 1 + 0.5 * np.exp(-0.01 * t)
        return -0.005 * np.exp(-0.01 * t) * np.cos(W * t) - a * W * np.sin(W * t)

    signals = [
        _cosine(1.0),                  # 0: steady oscillation -> lco
        _cosine(1.0, rate=-0.3),       # 1: geometric decay -> decay (extrapolated to 0)
        _cosine(1e-3, rate=0.2),       # 2: growing -> still running
        (creeping, creeping_d),        # 3: slow approach: small change per cycle, not settled
        _cosine(20.0),                 # 4: beyond max_amplitude -> diverged
        _cosine(1.0),                  # 5: solver failed -> unconverged
        _cosine(1.0),                  # 6: state turned NaN -> failed
        _cosine(1.0, rate=0.3),        # 7: NaN after growth -> diverged
    ]
    tr = _feed(signals, t_end=12.0)
    finite = torch.tensor([True] * 6 + [False, False])
    solver_ok = torch.tensor([True] * 5 + [False, True, True])
    status = tr.decide(crit, finite, solver_ok, final=False).tolist()
    assert status == [LCO, DECAY, RUNNING, RUNNING, DIVERGED, UNCONVERGED, FAILED, DIVERGED]
    # at t_end the undecided ones are unconverged
    final = tr.decide(crit, finite, solver_ok, final=True).tolist()
    assert final[2] == UNCONVERGED and final[3] == UNCONVERGED
    # stop=False keeps settled cases running until t_end
    keep = tr.decide(LCOCriteria(rtol=1e-4, stop=False), finite, solver_ok, final=False).tolist()
    assert keep[0] == RUNNING and keep[6] == FAILED


def test_the_creeping_case_would_pass_a_per_cycle_test_alone():
    """Why the Aitken (extrapolated) test exists: with a looser per-cycle tolerance the creeping
    amplitude passes the per-cycle change test but not the extrapolated one."""
    def y(t):
        return (1 + 0.5 * np.exp(-0.01 * t)) * np.cos(W * t)

    def yd(t):
        return (-0.005 * np.exp(-0.01 * t) * np.cos(W * t)
                - (1 + 0.5 * np.exp(-0.01 * t)) * W * np.sin(W * t))

    tr = _feed([(y, yd)], t_end=12.0)
    A, ok = tr.amplitudes([0], 3)
    per_cycle = float((A[0, 0, 0] - A[0, 0, 1]).abs() / A[0, 0, 0])
    assert per_cycle < 5e-3  # would pass rtol = 5e-3 per cycle ...
    status = tr.decide(LCOCriteria(rtol=5e-3), torch.tensor([True]), torch.tensor([True]),
                       final=False)
    assert status.item() == RUNNING  # ... but the remaining change (≈ 0.5·e^{-0.12}) is large


def test_case_at_rest_decays_at_t_end():
    def zero(t):
        return 0.0 * t

    tr = _feed([(zero, zero)], t_end=1.0)
    status = tr.decide(LCOCriteria(), torch.tensor([True]), torch.tensor([True]), final=True)
    assert status.item() == DECAY
