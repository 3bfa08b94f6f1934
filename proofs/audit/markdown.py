"""The audit's summary as markdown (:mod:`proofs.audit`)."""
from __future__ import annotations

import json
import math

def _fmt_ratio(v):
    if v is None:
        return "—"
    if v == math.inf:
        return "inf"
    return f"{v:.3f}"


def render_markdown(s: dict) -> str:
    fm = s["formats"]
    out = ["# fperr audit: shadow execution against derived bounds", "",
           f"{s['runs']} shadow runs ({s['samples_per_predicate_and_format']} samples per "
           f"predicate and format, {s['search_steps']} hill-climbing steps per seed, seed "
           f"{s['seed']}) in {s['elapsed_s']} s. Formats: {', '.join(fm)}.", ""]
    if s.get("module"):  # fperr audit --predicates MODULE
        out[-1:-1] = ["", f"Predicates of {s['module']}, with the tolerance table (and sign "
                      "filters) it declares in FPERR_TOLERANCES. The stress of its sign "
                      "tests is the rounding toward zero over |x| where the premise holds "
                      "(≥ 1: a wrong sign)."]
    nv = s["violation_count"]
    out.append(f"**Violations: {nv}**" + ("" if nv else " (every measured error within its "
                                            "bound, every decision within its brackets)"))
    out.append("")
    out += ["## Quantities: max |F[x] − x| / E[x] (soundness ≤ 1; tightness: close to 1)", "",
            "| predicate | quantity | derived bound | " + " | ".join(
                f"{f} E-ratio (R-ratio) | n" for f in fm) + " |",
            "|---|---|---|" + "---|---|" * len(fm)]
    for r in s["quantities"]:
        cells = []
        for f in fm:
            d = r["formats"][f]
            rr = f" ({_fmt_ratio(d['max_relative_ratio'])})" if d["max_relative_ratio"] is not None else ""
            cells.append(f"{_fmt_ratio(d['max_ratio'])}{rr} | {d['samples']}")
        out.append(f"| {r['predicate']} | {r['quantity']} | {r['bound']} | " + " | ".join(cells) + " |")
    out += ["", "## Checks", "",
            "stress: the largest share of the bracket gap (T − T−, T+ − T) that rounding "
            "consumed in the direction that could flip the decision, over samples near the "
            "threshold (T − 2·(T − T−) ≤ x ≤ T + 2·(T+ − T)); for a sign test, |F[x] − x|/|x| "
            "where its premise holds; "
            "flip: the closest approach to a forbidden flip (rounding error over the distance "
            "x would have to cross, at least the gap; ≥ 1 outside [T−, T+] is a violation); "
            "zone: samples whose exact value lay between T− and T+; n: evaluations; "
            "viol.: forbidden disagreements (premise holding).", "",
            "| predicate | line | check | kind | " + " | ".join(
                f"{f} stress / flip / zone / n / viol." for f in fm) + " |",
            "|---|---|---|---|" + "---|" * len(fm)]
    for r in s["checks"]:
        cells = []
        for f in fm:
            d = r["formats"][f]
            if not d.get("evaluated"):
                cells.append("not reached")
                continue
            extra = ""
            if d["premise_failed"]:
                extra += f" ({d['premise_failed']} w/o premise)"
            if d["undecided"]:
                extra += f" ({d['undecided']} undecided)"
            flip = _fmt_ratio(d["max_flip"]) if r["kind"] == "bracket" else "—"
            cells.append(f"{_fmt_ratio(d['max_stress'])} / {flip} / {d['in_zone']} / "
                         f"{d['evaluated']} / **{d['violations']}**{extra}")
        out.append(f"| {r['predicate']} | {r['line']} | `{r['check']}` | {r['kind']} | "
                   + " | ".join(cells) + " |")
    out += ["", "## Tolerances: max |F[T] − T| / (R[T]·T)", "",
            "| dim | tolerance | derived | " + " | ".join(fm) + " |",
            "|---|---|---|" + "---|" * len(fm)]
    for t in s["tolerances"]:
        cells = [(_fmt_ratio(t["formats"][f]["max_ratio"]) +
                  ("" if t["formats"][f]["same"] else " MISMATCH")) if f in t["formats"] else "—"
                 for f in fm]
        out.append(f"| {t['dim']}D | {t['tolerance']} | {t['bound']} | " + " | ".join(cells) + " |")
    out += _worst_cases(s.get("worst_cases", []))
    if s["violations"]:
        out += ["", "## Violations (reproduce with proofs.audit.replay)", ""]
        for v in s["violations"][:50]:
            out.append("- " + json.dumps(v))
    return "\n".join(out) + "\n"



def _worst_cases(recs: list) -> list:
    if not recs:
        return []
    out = ["", "## Worst cases per quantity (units of ε·L^p, L the largest bounding-box edge)",
           "", "worst: the largest measured |F[x] − x|; first order: the largest "
           "Σ|∂x/∂y_k|·½ulp(y_k) over the configurations searched; bound: the derived E; "
           "slack: where worst/bound < 0.5, whether the rules or the search leave it.", "",
           "| dim | algorithm | quantity | format | worst | first order | bound | ratio | "
           "slack |", "|---|---|---|---|---|---|---|---|---|"]
    for r in recs:
        w = "—" if r["worst_error_units"] is None else f"{r['worst_error_units']:.2f}"
        sl = (r["slack"] or "").split(":")[0]
        out.append(f"| {r['dim']}D | {r['algorithm']} | {r['quantity']} | {r['format']} | "
                   f"{w} | {r['first_order_units']:.2f} | {r['bound_units']:.2f} | "
                   f"{_fmt_ratio(r['ratio'])} | {sl} |")
    return out
