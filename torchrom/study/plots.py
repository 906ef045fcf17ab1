"""Figures of sweep tables (matplotlib, Agg backend), written atomically."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..errors import InputError
from ..io import atomic_path, check_can_write

#: marker per status: settled LCOs filled, everything else hollow or crossed
_MARKERS = {"lco": ("o", True), "decay": ("v", False), "unconverged": ("s", False),
            "diverged": ("^", False), "failed": ("x", True)}


def parameter_plot(table: pd.DataFrame, path, *, x: str, y: str = "amplitude",
                   hue: str | None = None, title: str | None = None,
                   force: bool = False) -> Path:
    """y against the swept parameter x, one line per value of ``hue``; markers show the status
    (filled circle: converged LCO). Returns the path written (PNG/PDF by its suffix)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for col in (x, y) + ((hue,) if hue else ()):
        if col not in table.columns:
            raise InputError(f"plot: no column {col!r} in the results table; it has "
                             f"{list(table.columns)}")
    path = check_can_write(path, force, "figure")
    fig, ax = plt.subplots(figsize=(6.4, 4.4), constrained_layout=True)
    groups = table.groupby(hue, sort=True) if hue else [(None, table)]
    for key, grp in groups:
        grp = grp.sort_values(x)
        label = f"{hue} = {key:g}" if hue else None
        (line,) = ax.plot(grp[x], grp[y], "-", lw=1.2, label=label)
        for status, (marker, filled) in _MARKERS.items():
            sel = grp[grp["status"] == status]
            if len(sel):
                ax.plot(sel[x], sel[y], marker, ms=5, color=line.get_color(),
                        mfc=line.get_color() if filled else "none", ls="none")
    handles = [plt.Line2D([], [], marker=m, ls="none", color="0.3", mfc="0.3" if f else "none",
                          label=s) for s, (m, f) in _MARKERS.items()
               if (table["status"] == s).any()]
    ax.legend(handles=ax.get_legend_handles_labels()[0] + handles, fontsize=8)
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title, fontsize=10)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path
