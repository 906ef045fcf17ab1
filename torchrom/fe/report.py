"""Plain-text tables of modal results (used by ``torchrom goland`` and ``torchrom modes``)."""

from __future__ import annotations


def mode_table(records: list[dict]) -> str:
    """Fixed-width table: mode, (paper Hz, model Hz, % diff) or Hz, kind, content fractions."""
    with_ref = any("paper_hz" in r for r in records)
    head = (f"{'mode':>4}  {'paper Hz':>9}  {'model Hz':>9}  {'diff %':>7}  {'kind':<9}"
            if with_ref else f"{'mode':>4}  {'Hz':>11}  {'kind':<9}")
    head += "  bend/tors/in-plane/axial content"
    lines = [head, "-" * len(head)]
    for r in records:
        content = "/".join(f"{r.get('content_' + k, 0.0):.2f}"
                           for k in ("bending", "torsion", "in-plane", "axial"))
        if with_ref:
            ref = r.get("paper_hz")
            ref_s = f"{ref:9.3f}" if ref is not None else f"{'-':>9}"
            diff = r.get("diff_pct")
            diff_s = f"{diff:+7.2f}" if diff is not None else f"{'-':>7}"
            lines.append(f"{r['mode']:>4}  {ref_s}  {r['frequency_hz']:9.3f}  {diff_s}  "
                         f"{r['kind']:<9}  {content}")
        else:
            lines.append(f"{r['mode']:>4}  {r['frequency_hz']:11.5g}  {r['kind']:<9}  {content}")
    return "\n".join(lines)
