"""Paper tables against the synthesized ones (proofs/data/synth_*.toml) on the meshes of
`fperr demo` (defaults, n = 16) and its degenerate cases: pairs per kind and level,
pairs that moved, inconsistencies. Run: PYTHONPATH=. python3 benchmarks/synth_compare.py"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from predicates import intersect
from predicates.registration.pictures.demo import degenerate_cases
from predicates.registration.examples import example
from proofs.tables import load_overrides

DATA = Path(__file__).resolve().parents[1] / "proofs" / "data"
TABLES = {d: load_overrides(DATA / f"synth_{d}d.toml") for d in (2, 3)}


def _keys(res):
    return {k: set(map(tuple, res[k].keys())) for k in res.kinds}


def compare(name, sim, cut, dim, dtype, inside=None):
    a = intersect(*sim, *cut, dtype=dtype)
    b = intersect(*sim, *cut, dtype=dtype, tolerances=TABLES[dim])
    ka, kb = _keys(a), _keys(b)
    moved = {k: (len(ka[k] - kb[k]), len(kb[k] - ka[k])) for k in a.kinds
             if ka[k] != kb[k]}
    inc = "" if inside is None else \
        f"  inconsistencies {a.inconsistencies(inside)} -> {b.inconsistencies(inside)}"
    diff = ", ".join(f"{k} -{m}/+{p}" for k, (m, p) in moved.items()) or "no pair moved"
    print(f"{name} [{np.dtype(dtype).name}]: total {a.total} -> {b.total}; {diff}{inc}")
    return moved


def main(n: int = 16) -> int:
    for dtype in (np.float64, np.float32):
        ex2 = example("circle", n, segments=4 * n)
        compare(f"demo 2D circle {n}x{n}", ex2["sim"], ex2["cut"], 2, dtype)
        n3 = n // 2
        ex3 = example("sphere", n3, subdivisions=int(np.clip(round(np.log2(n3)), 1, 5)))
        compare(f"demo 3D sphere {n3}^3", ex3["sim"], ex3["cut"], 3, dtype)
        for name, variants, inside in degenerate_cases(n):
            for i, (sim, cut) in enumerate(variants):
                compare(f"{name} #{i}", sim, cut, sim[0].shape[1], dtype, inside)
    return 0


if __name__ == "__main__":
    sys.exit(main(*(int(a) for a in sys.argv[1:])))
