"""Flutter figures: V-g / V-f diagrams and state-space root loci (matplotlib, Agg backend).

Layout; drawing delegated to matplotlib. Every figure is written atomically.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..io import atomic_path
from .flutter import ModeSweep


def _figure(nrows=1, ncols=1, **kw):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt, *plt.subplots(nrows, ncols, **kw)


def plot_vg(
    sweep: ModeSweep,
    path: str | os.PathLike,
    x: str = "velocity",
    velocity_label: str = "velocity",
    title: str | None = None,
    altitude_label: str = "altitude (ft)",
    beside=None,
) -> Path:
    """Damping g and frequency (Hz) of every tracked mode against velocity (or altitude);
    the axis labels carry the model's units. ``beside(fig, spec)``: draws a panel to the right
    of the two diagrams into the gridspec cell ``spec`` (the flutter mode's shape,
    :func:`torchrom.post.pictures.flutter_panel`)."""
    if beside is None:
        plt, fig, (ax_g, ax_f) = _figure(2, 1, sharex=True, figsize=(7, 7))
    else:
        plt, fig, _ = _figure(figsize=(14, 7))
        fig.clf()
        grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.1))
        ax_g = fig.add_subplot(grid[0, 0])
        ax_f = fig.add_subplot(grid[1, 0], sharex=ax_g)
        beside(fig, grid[:, 1])
    xs = (
        sweep.velocity_by_mode
        if x == "velocity"
        else np.repeat(np.asarray(sweep.altitude)[:, None], sweep.damping.shape[1], axis=1)
    )
    for j in range(sweep.damping.shape[1]):
        order = np.argsort(xs[:, j])
        ax_g.plot(xs[order, j], sweep.damping[order, j], marker=".", label=f"mode {j + 1}")
        ax_f.plot(xs[order, j], sweep.frequency_hz[order, j], marker=".")
    ax_g.axhline(0.0, color="k", lw=0.8)
    ax_g.set_ylabel("damping g (-)")
    ax_f.set_ylabel("frequency (Hz)")
    ax_f.set_xlabel(velocity_label if x == "velocity" else altitude_label)
    finite = sweep.damping[np.isfinite(sweep.damping)]
    if finite.size:
        lo, hi = np.percentile(finite, [1, 99])
        pad = 0.1 * max(hi - lo, 1e-3)
        ax_g.set_ylim(lo - pad, hi + pad)
    ax_g.legend(fontsize="small", ncol=3)
    ax_g.grid(True, alpha=0.3)
    ax_f.grid(True, alpha=0.3)
    fig.suptitle(title or f"{sweep.method} flutter sweep")
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return path


def plot_root_locus(
    sweep: dict,
    path: str | os.PathLike,
    title: str | None = None,
    max_frequency_hz: float | None = None,
) -> Path:
    """State-space eigenvalues along a sweep (``state_space_sweep`` dict), coloured by point."""
    plt, fig, ax = _figure(figsize=(7, 6))
    eig = np.asarray(sweep["eigenvalues"])
    n = len(eig)
    colors = plt.cm.viridis(np.linspace(0, 1, n))
    for i in range(n):
        s = eig[i][eig[i].imag >= 0]
        if max_frequency_hz is not None:
            s = s[s.imag <= 2 * np.pi * max_frequency_hz]
        ax.plot(s.real, s.imag / (2 * np.pi), ".", color=colors[i], ms=4)
    ax.axvline(0.0, color="k", lw=0.8)
    ax.set_xlabel("real part (1/s)")
    ax.set_ylabel("frequency (Hz)")
    ax.grid(True, alpha=0.3)
    ax.set_title(title or "state-space root locus")
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return path
