"""The Goland pipeline of several damping methods at once (torchrom.paper.pipeline.
goland_pipelines): one FE identification and one aerodynamics computation, and folders that are
exactly what each method's pipeline alone builds (and reuses)."""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from torchrom.paper.pipeline import GolandPipeline, goland_pipeline, goland_pipelines

#: a small pipeline (3 linear + 2 dual modes, a coarse DLM mesh): the same stages as the
#: study's, in seconds
SMALL = GolandPipeline(n_linear=3, n_dual=2, dual_amplitudes=4, dual_combinations=((1, 1),
                                                                                 (1, 2)),
                       aero_modes=3, lags=2, boxes=(2, 4))
TENSORS = ("M", "K1", "K2", "K3", "D1", "D2", "D3")


def test_pipelines_share_the_fe_work_and_match_each_pipeline_alone(tmp_path):
    lines = []
    both = goland_pipelines(SMALL, {"decomposition": tmp_path / "a", "exact": tmp_path / "b"},
                            log=lines.append)
    # one identification for both ROMs, one aerodynamics computation
    assert sum(ln.startswith("identify:") for ln in lines) == 1
    assert sum(ln.startswith("aero:") for ln in lines) == 1
    exact = dataclasses.replace(SMALL, damping="exact")
    for damping, opt in (("decomposition", SMALL), ("exact", exact)):
        alone = goland_pipeline(opt, tmp_path / f"alone_{damping}", log=lambda _m: None)
        shared = both[damping]
        assert shared.rom.metadata["damping"]["method"] == damping
        for name in TENSORS:  # bit for bit: the damping is identified after the stiffness
            assert torch.equal(getattr(shared.rom, name), getattr(alone.rom, name)), name
        assert np.array_equal(np.load(shared.files["basis.npz"])["Phi"],
                              np.load(alone.files["basis.npz"])["Phi"])
        assert shared.model.content_hash() == alone.model.content_hash()
        assert shared.flutter["state_space"] == alone.flutter["state_space"]
    assert not torch.equal(both["exact"].rom.D3, both["decomposition"].rom.D3)
    # the shared folders are the single pipelines' own: each reuses everything in its folder
    again = goland_pipeline(exact, tmp_path / "b", log=lambda _m: None)
    assert {"goland.bdf", "rom.npz", "basis.npz", "aero.npz", "flutter.json"} <= set(
        again.reused)
