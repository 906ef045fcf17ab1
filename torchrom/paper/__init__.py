"""The paper's study end to end (``torchrom paper``): the heavy Goland wing of Wang, Song,
Mignolet & Chen (AIAA J. 2021), Sec. IV — Figs. 9–13, Tables 2–3 and a findings report.

- :mod:`.pipeline`  FE model -> identified ROM -> aerodynamics on its basis -> flutter (cached)
- :mod:`.cache`     intermediate files keyed by the hash of their inputs
- :mod:`.linear`    the batched simulator's linear growth rates vs the eigenvalues; Table 3
- :mod:`.findings`  the paper's stated findings checked against our tables
- :mod:`.report`    ``report.md``
- :mod:`.study`     :func:`run_paper`, the orchestration
- :mod:`.beside`    the stages that need only the model, on a second process
"""

from .pipeline import GolandPipeline, PipelineResult, goland_pipeline

__all__ = ["GolandPipeline", "PipelineResult", "goland_pipeline"]
