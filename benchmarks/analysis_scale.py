"""How the instrumented analysis scales: time and peak memory of deriving the bound of
one expression, by size (fperr/state.py, fperr/tracked.py: Fraction states, ε-dependent
fields as reduced rational functions of ε^(1/4), texts built on demand).

    python benchmarks/analysis_scale.py [--json OUT.json] [--quick]

Cases (each in a fresh subprocess, after fperr and sympy are imported, so the figures
are the analysis's own):

* ``sum``: x1·y1 + ... + xn·yn, left to right (n = 1,000 and 10,000);
* ``det7``: a 7×7 determinant by Laplace expansion along the first row, minors not
  shared (13,699 operations);
* ``eps``: (x1·y1 − T) + (x2·y2 − T) + ... with T = 21ε·L² a tolerance: every magnitude
  depends on ε (n = 300 and 1,000 operations).

Time is wall time of building the expression and ``fperr.bounds`` of the result (run
without tracemalloc); peak memory is tracemalloc's peak over the same work in a second
run (Python allocations: what the analysis holds).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
import tracemalloc


def _det(m):
    """Laplace expansion along the first row (no shared minors), alternating signs."""
    n = len(m)
    if n == 1:
        return m[0][0]
    total = None
    for j in range(n):
        minor = [row[:j] + row[j + 1:] for row in m[1:]]
        term = m[0][j] * _det(minor)
        total = term if total is None else (total + term if j % 2 == 0 else total - term)
    return total


def build(case: str, n: int):
    import fperr
    if case == "sum":
        s = fperr.coord("x0") * fperr.coord("y0")
        for i in range(1, n):
            s = s + fperr.coord(f"x{i}") * fperr.coord(f"y{i}")
        return s
    if case == "det7":
        m = [[fperr.coord(f"a{i}{j}") for j in range(n)] for i in range(n)]
        return _det(m)
    if case == "eps":
        T = fperr.const(21 * fperr.eps) * fperr.exact_input("L^2", 1, 2, nonnegative=True,
                                                           tight=True)
        acc, ops = fperr.coord("x0") * fperr.coord("y0") - T, 2
        while ops < n:
            acc = acc + (fperr.coord(f"x{ops}") * fperr.coord(f"y{ops}") - T)
            ops += 3
        return acc
    raise ValueError(case)


def run_case(case: str, n: int, memory: bool) -> dict:
    """One measurement in this process (called in a subprocess)."""
    import fperr
    fperr.bounds(fperr.coord("warm") * fperr.coord("up"))  # imports, sympy caches
    if memory:
        tracemalloc.start()
    t0 = time.perf_counter()
    x = build(case, n)
    b = fperr.bounds(x)
    seconds = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1] / 2**20 if memory else None
    ops = sum(1 for t in x.walk() if t.args)
    return {"case": case, "n": n, "operations": ops, "seconds": seconds, "peak_MiB": peak,
            "bound": b.text() if b.E_int is not None else str(b.E)[:60]}


CASES = [("sum", 1000), ("sum", 10000), ("det7", 7), ("eps", 300), ("eps", 1000)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the figures here")
    ap.add_argument("--quick", action="store_true", help="the small cases only")
    ap.add_argument("--one", nargs=3, metavar=("CASE", "N", "MEMORY"), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.one:
        print(json.dumps(run_case(a.one[0], int(a.one[1]), a.one[2] == "1")))
        return 0
    rows = []
    cases = CASES[::2] if a.quick else CASES
    print(f"{'case':6} {'n':>6} {'ops':>7} {'time s':>8} {'peak MiB':>9}  bound")
    for case, n in cases:
        got = {}
        for memory in (False, True):
            out = subprocess.run([sys.executable, __file__, "--one", case, str(n),
                                  "1" if memory else "0"], capture_output=True, text=True,
                                 check=True)
            got[memory] = json.loads(out.stdout)
        row = dict(got[False], peak_MiB=got[True]["peak_MiB"])
        rows.append(row)
        print(f"{case:6} {n:>6} {row['operations']:>7} {row['seconds']:>8.2f} "
              f"{row['peak_MiB']:>9.1f}  {row['bound']}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
