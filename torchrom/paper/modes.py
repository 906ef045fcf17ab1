"""The paper's modes matched to ours by kind (for Fig. 13 and its finding).

The paper's Table 2 says what its first five modes are (``paper_reference().table2_kinds``:
bending, torsion, transverse, bending-torsion, in-plane); our reconstruction orders its modes
differently (e.g. its mode 4 is in-plane). Each paper mode, in order, takes the lowest of our
modes not yet taken whose kind is compatible: ``bending`` / ``torsion`` / ``in-plane`` the same
kind, ``transverse`` and ``bending-torsion`` any out-of-plane mode (bending or torsion). So the
paper's q4 (its transverse bending–torsion mode) is compared with our first out-of-plane mode
after those matched to its modes 1–3, not with our in-plane mode 4.

A mode's kind is the largest of its content shares (:func:`torchrom.fe.kinds.classify`:
bending, torsion, in-plane, axial; shares of the squared displacement, summing to 1). Where a
mode is named, :func:`kind_label` gives its kind with the shares, so a mixed mode (e.g. 0.44
bending, 0.26 torsion, 0.29 in-plane) is not read as a pure one; :func:`kind_margin` says by
how much the kind beats the runner-up.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from ..fe.kinds import kind_label as kind_label  # noqa: F401 - used by report and study

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


def kind_margin(content: Mapping[str, float]) -> tuple[str, float, str, float]:
    """(kind, its share, runner-up kind, its share) of a mode's content shares."""
    (a, ka), (b, kb) = sorted(((v, k) for k, v in content.items()), reverse=True)[:2]
    return ka, a, kb, b
