"""Branch points finished again from their neighbours (torchrom.study.branch): which neighbour
each failed point is retried from (the end-to-end branch runs are in test_commands_branch.py)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

import torchrom.study.branch as branch
from torchrom.periodic.certify import UNCERTIFIED


def _retries(monkeypatch, status, branches, succeed_from):
    """The (failed point, source) pairs tried; a retry succeeds when its source is in
    ``succeed_from``."""
    calls = []

    def fake(system, res, bad, src, C, cfg):
        calls.append(list(zip(bad.tolist(), src.tolist())))
        new = np.asarray(res.status).copy()
        for i, j in zip(bad, src):
            if j in succeed_from:
                new[i] = "lco"
        return SimpleNamespace(status=new)

    monkeypatch.setattr(branch, "_finish_from", fake)
    cfg = SimpleNamespace(certificate=SimpleNamespace(finish=True))
    res = SimpleNamespace(status=np.array(status, dtype=object))
    out = branch._finish_from_neighbours(None, res, branches, None, cfg)
    return calls, list(out.status)


def test_a_failed_point_is_retried_from_its_nearest_then_its_other_neighbour(monkeypatch):
    """Point 2 fails: first from point 1 (nearest; a tie goes to the lower index), then from
    point 3 (the other side), which succeeds. Point 6 fails on branch 1, whose only certified
    point is 5: one retry. Points of another branch are never sources."""
    status = ["lco", "lco", UNCERTIFIED, "lco", "hopf", "lco", UNCERTIFIED]
    branches = [0, 0, 0, 0, 1, 1, 1]
    calls, final = _retries(monkeypatch, status, branches, succeed_from={3})
    assert calls == [[(2, 1), (6, 5)], [(2, 3)]]
    assert final == ["lco", "lco", "lco", "lco", "hopf", "lco", UNCERTIFIED]


def test_a_point_certified_on_the_first_retry_is_not_retried_again(monkeypatch):
    calls, final = _retries(monkeypatch, ["lco", UNCERTIFIED, "lco", "lco"], [0, 0, 0, 0],
                            succeed_from={0})
    assert calls == [[(1, 0)]] and final == ["lco"] * 4


def test_nothing_to_retry(monkeypatch):
    calls, final = _retries(monkeypatch, ["lco", "lco"], [0, 0], succeed_from=set())
    assert calls == [] and final == ["lco", "lco"]
