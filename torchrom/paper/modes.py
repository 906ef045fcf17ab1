"""The paper's modes matched to ours by kind (for Fig. 13 and its finding).

The paper's Table 2 says what its first five modes are (``paper_reference().table2_kinds``:
bending, torsion, transverse, bending-torsion, in-plane); our reconstruction orders its modes
differently (e.g. its mode 4 is in-plane). Each paper mode, in order, takes the lowest of our
modes not yet taken whose kind is compatible: ``bending`` / ``torsion`` / ``in-plane`` the same
kind, ``transverse`` and ``bending-torsion`` any out-of-plane mode (bending or torsion). So the
paper's q4 (its transverse bending–torsion mode) is compared with our first out-of-plane mode
after those matched to its modes 1–3, not with our in-plane mode 4.
"""

from __future__ import annotations

from collections.abc import Sequence

#: our kinds each paper kind accepts
COMPATIBLE = {"bending": ("bending",), "torsion": ("torsion",), "in-plane": ("in-plane",),
              "transverse": ("bending", "torsion"), "bending-torsion": ("bending", "torsion")}


def paper_mode_map(ours: Sequence[str | None], paper: Sequence[str]) -> dict[int, int]:
    """{paper mode: our mode} (1-based) for every paper mode with a compatible mode of ours."""
    taken: set[int] = set()
    out: dict[int, int] = {}
    for i, kind in enumerate(paper):
        ok = COMPATIBLE.get(kind, (kind,))
        for j, k in enumerate(ours):
            if j not in taken and k in ok:
                taken.add(j)
                out[i + 1] = j + 1
                break
    return out
