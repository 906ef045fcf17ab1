"""Pictures of a :class:`~torchrom.post.motions.Motion` without a viewer (matplotlib, Agg).

- :func:`mode_picture`: one frame (a mode, a phase of the flutter mode, an instant of an LCO)
  as the deformed wing in 3-D over its undeformed outline (PNG, PDF, SVG);
- :func:`lco_gif`: every frame of a motion as a GIF that loops over one period or cycle
  (matplotlib's ``PillowWriter``);
- :func:`draw_frames`: the drawing itself into a 3-D axes of any figure (the flutter mode beside
  the V-g diagram of ``torchrom flutter --plot``).

Faces are coloured by the size of their grids' translation; the axes are the basic frame's, in
the mesh's length unit, at true aspect (an axis that spans less than a tenth of the largest is
widened to that, so a thin wing's deflection shows). A mode has no amplitude of its own: it is
drawn with its largest translation at ``fraction`` of the span and the figure says by how much
the displacements are magnified; an LCO is drawn at its true size unless ``scale`` says
otherwise, and the figure says that too.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import atomic_path
from ..rom.shapes import unit_label
from .motions import Motion

#: an axis spanning less than this fraction of the largest is widened to it
MIN_ASPECT = 0.1
#: where a mode's largest translation is drawn by default, as a fraction of the span
MODE_FRACTION = 0.1


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def mode_scale(motion: Motion, fraction: float = MODE_FRACTION) -> float:
    """The magnification that draws the motion's largest translation at ``fraction`` of the
    span (1 for a motion that does not move)."""
    if not (np.isfinite(fraction) and fraction > 0):
        raise InputError(f"--fraction: expected a positive fraction of the span, got {fraction}")
    largest = float(np.linalg.norm(motion.displacements[..., :3], axis=-1).max())
    return fraction * motion.shapes.span() / largest if largest > 0 else 1.0


def _limits(motion: Motion, scale: float) -> tuple[np.ndarray, np.ndarray]:
    xyz = motion.shapes.xyz
    pts = np.concatenate([xyz[None], xyz[None] + scale * motion.displacements[..., :3]])
    lo, hi = pts.reshape(-1, 3).min(axis=0), pts.reshape(-1, 3).max(axis=0)
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    half = np.maximum(half, MIN_ASPECT * half.max() + 1e-30)
    return mid - half, mid + half


def draw_frames(ax, motion: Motion, frames, scale: float, alphas=None, colorbar=None) -> None:
    """Draw the undeformed outline and each frame of ``frames`` deformed by ``scale`` into the
    3-D axes ``ax`` (faces coloured by |translation| on one scale for all frames of the
    motion; ``colorbar``: a figure to add the colour bar to)."""
    import matplotlib
    from matplotlib import cm, colors
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    s = motion.shapes
    unit = unit_label(s)
    mag = np.linalg.norm(motion.displacements[..., :3], axis=-1)
    norm = colors.Normalize(0.0, float(mag.max()) or 1.0)
    cmap = matplotlib.colormaps["viridis"]
    faces = [f for f in (s.quads, s.trias) if len(f)]
    for f in faces:  # the undeformed outline
        ax.add_collection3d(Poly3DCollection(s.xyz[f], facecolors="none", edgecolors="0.75",
                                             linewidths=0.3))
    if len(s.lines):
        ax.add_collection3d(Line3DCollection(s.xyz[s.lines], colors="0.75", linewidths=0.3))
    for n, i in enumerate(frames):
        u = motion.displacements[i]
        xyz = s.xyz + scale * u[:, :3]
        alpha = 1.0 if alphas is None else alphas[n]
        for f in faces:
            col = cmap(norm(mag[i][f].mean(axis=1)))
            ax.add_collection3d(Poly3DCollection(xyz[f], facecolors=col, edgecolors="k",
                                                 linewidths=0.2, alpha=alpha))
        if len(s.lines):
            ax.add_collection3d(Line3DCollection(xyz[s.lines], colors=cmap(norm(
                mag[i][s.lines].mean(axis=1))), linewidths=1.0, alpha=alpha))
    lo, hi = _limits(motion, scale)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo)
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):  # a thin axis at true aspect has little room
        axis.set_major_locator(MaxNLocator(4))
    ax.set_xlabel(f"x ({unit})")
    ax.set_ylabel(f"y ({unit})")
    ax.set_zlabel(f"z ({unit})")
    if colorbar is not None:
        sm = cm.ScalarMappable(norm=norm, cmap=cmap)
        what = "" if motion.scale == "physical" else f"; {motion.scale}"
        colorbar.colorbar(sm, ax=ax, shrink=0.6, pad=0.12, label=f"|translation| ({unit}{what})")


def _magnified(scale: float) -> str:
    return "true size" if scale == 1 else f"displacements ×{scale:.3g}"


def mode_picture(path, motion: Motion, index: int = 0, fraction: float = MODE_FRACTION,
                 scale: float | None = None, elev: float = 25.0, azim: float = -60.0) -> Path:
    """Frame ``index`` of ``motion`` as a 3-D picture (module docstring); ``scale`` overrides
    the magnification that ``fraction`` sets."""
    if not 0 <= index < len(motion.keys):
        raise InputError(f"frame {index}: the motion has frames 0..{len(motion.keys) - 1}")
    k = mode_scale(motion, fraction) if scale is None else float(scale)
    plt = _pyplot()
    fig = plt.figure(figsize=(8, 6))
    ax = fig.add_subplot(projection="3d")
    draw_frames(ax, motion, [index], k, colorbar=fig)
    ax.view_init(elev=elev, azim=azim)
    ax.set_title(f"{motion.title}\n{motion.label(index)}; {_magnified(k)}", fontsize="medium")
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def lco_gif(path, motion: Motion, scale: float = 1.0, fps: int = 12, elev: float = 25.0,
            azim: float = -60.0) -> Path:
    """Every frame of ``motion`` as a looping GIF (module docstring)."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    if not (np.isfinite(scale) and scale > 0):
        raise InputError(f"--scale: expected a positive magnification, got {scale}")
    plt = _pyplot()
    fig = plt.figure(figsize=(7, 5.5))
    ax = fig.add_subplot(projection="3d")

    def frame(i):
        ax.clear()
        draw_frames(ax, motion, [i], scale)
        ax.view_init(elev=elev, azim=azim)
        ax.set_title(f"{motion.title}\n{motion.label(i)}; {_magnified(scale)}",
                     fontsize="medium")
        return []

    anim = FuncAnimation(fig, frame, frames=len(motion.keys), blit=False)
    path = Path(path)
    with atomic_path(path) as tmp:
        anim.save(tmp, writer=PillowWriter(fps=int(fps)), dpi=80)
    plt.close(fig)
    return path


def flutter_panel(fraction: float = MODE_FRACTION):
    """A drawer for :func:`torchrom.aero.plots.plot_vg`'s ``beside``: ``draw(fig, spec,
    motion)`` puts the flutter mode (phases 0° and 90° of its cycle, the latter fainter) into a
    3-D axes at ``spec``."""
    def draw(fig, spec, motion: Motion):
        ax = fig.add_subplot(spec, projection="3d")
        k = mode_scale(motion, fraction)
        quarter = int(np.argmin(np.abs(((motion.values - 90.0) + 180) % 360 - 180)))
        draw_frames(ax, motion, [0, quarter], k, alphas=[1.0, 0.35])
        ax.set_title(f"{motion.title}\nphases 0° and {motion.values[quarter]:.0f}° (faint); "
                     f"{_magnified(k)}", fontsize="small")
        return ax

    return draw
