"""Plain-text tables of modal results (used by ``torchrom goland`` and ``torchrom modes``)."""

from __future__ import annotations


def mode_table(records: list[dict]) -> str:
    """Fixed-width table: mode, (paper Hz, model Hz, % diff), (model Hz, Nastran Hz, % diff) or
    Hz, kind, content fractions."""
    if any("nastran_hz" in r for r in records):
        return _nastran_table(records)
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


def _content(r: dict) -> str:
    return "/".join(f"{r.get('content_' + k, 0.0):.2f}"
                    for k in ("bending", "torsion", "in-plane", "axial"))


def _nastran_table(records: list[dict]) -> str:
    head = (f"{'mode':>4}  {'torchrom Hz':>12}  {'Nastran Hz':>12}  {'diff %':>8}  {'kind':<9}"
            "  bend/tors/in-plane/axial content")
    lines = [head, "-" * len(head)]
    for r in records:
        ref = r.get("nastran_hz")
        ref_s = f"{ref:12.6g}" if ref is not None else f"{'-':>12}"
        diff = r.get("diff_pct")
        if diff is not None:
            diff_s = f"{diff:+8.3f}"
        elif "diff_hz" in r:
            diff_s = f"{'rigid':>8}"
        else:
            diff_s = f"{'-':>8}"
        lines.append(f"{r['mode']:>4}  {r['frequency_hz']:12.6g}  {ref_s}  {diff_s}  "
                     f"{r['kind']:<9}  {_content(r)}")
    return "\n".join(lines)
