"""Assembling one result from runs of parts of a batch (torchrom.sim.result.gather_results)."""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.sim.result import History, SimulationResult, gather_results


def _result(status, amp, hist=None):
    B = len(status)
    return SimulationResult(
        output_names=["y"], status=np.array(status), steps=np.arange(B), time=np.ones(B),
        amplitude=np.array(amp, dtype=float)[:, None], frequency_hz=np.full(B, 2.0),
        amplitude_change=np.zeros(B), solver_error=np.zeros(B), q=np.zeros((B, 2)),
        v=np.zeros((B, 2)), histories=hist or {}, wall_time_s=1.5, case_steps=10 * B,
        xi=np.zeros((B, 1)))


def test_parts_land_at_their_indices_with_histories_and_totals():
    h = History(np.array([0.0, 1.0]), np.zeros((2, 1)), ["y"])
    a = _result(["lco", "lco"], [1.0, 2.0], {1: h})
    b = _result(["diverged"], [9.0])
    res = gather_results([(np.array([2, 0]), a), (np.array([1]), b)], 3)
    assert list(res.status) == ["lco", "diverged", "lco"]  # longer strings are not cut
    np.testing.assert_array_equal(res.amplitude[:, 0], [2.0, 9.0, 1.0])
    assert list(res.histories) == [0] and res.histories[0] is h
    assert res.wall_time_s == 3.0 and res.case_steps == 30


def test_every_case_exactly_once():
    a = _result(["lco"], [1.0])
    with pytest.raises(ValueError, match="exactly once"):
        gather_results([(np.array([0]), a)], 2)
    with pytest.raises(ValueError, match="exactly once"):
        gather_results([(np.array([0]), a), (np.array([0]), a)], 1)
