"""The flutter mode's shape beside the V-g diagram of ``torchrom flutter ROM.npz AERO.npz
--plot`` (:func:`torchrom.post.pictures.flutter_panel`): drawn where the ROM keeps its basis on
the deck's grids and the p-k found a flutter point; otherwise the V-g diagram alone, with a
line saying why."""

from __future__ import annotations

#: frames of the flutter mode's cycle (the panel draws phases 0° and 90°)
PHASES = 4


def remember_rom(args, rom, rom_path) -> None:
    """Keep the ROM of the ROM form for :func:`beside` (its shapes, if any)."""
    args.shape_rom = (rom, str(rom_path))


def beside(args, structure, table, result, sweep) -> dict:
    """``plot_vg`` keyword arguments: ``{"beside": drawer}`` of the flutter mode of the p-k
    ``result`` (a matched point or a speed at a density) found on ``sweep``, or {} (the V-g
    diagram alone: a goland or deck run, a ROM without shapes, no flutter point)."""
    rom, where = getattr(args, "shape_rom", (None, ""))
    if rom is None or result is None or getattr(result, "velocity", None) is None:
        return {}
    if rom.shapes is None:
        print(f"  {where}: no mode shapes on the deck's grids (identify again to keep them): "
              f"the V-g figure without the flutter mode")
        return {}
    from ..aero.flutter_mode import pk_flutter_mode
    from ..post.motions import flutter_motion
    from ..post.pictures import flutter_panel

    fm = pk_flutter_mode(structure, table, result.velocity, result.density, sweep, result.mode)
    unit = rom.shapes.length_unit or "length unit"
    motion = flutter_motion(rom.shapes, fm.vector, fm.eigenvalue, PHASES,
                            f"flutter mode {fm.mode + 1}: {fm.frequency_hz:.4g} Hz at "
                            f"{fm.velocity:.4g} {unit}/s")
    draw = flutter_panel()
    return {"beside": lambda fig, spec: draw(fig, spec, motion)}
