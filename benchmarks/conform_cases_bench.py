"""The conforming tetrahedralization beside the registration on the cases of docs/split.md
("The conforming tetrahedralization", "Progressive cuts"), timed in the same run (figures in
README.md, "The conforming cut on cracks and progressive cuts").

Cases: Kuhn n (default 16) × a flat disc crack of radius 0.5 h, 1.2 h and 3 h (the tests' disc:
24 fan triangles, tilted by ``rotation(3, 7)``, centred at ½ + (0.3, 0.2, 0.1)·h) and of
radius 0.05 h entirely inside one cell (centred at ½ + (0.62, 0.35, 0.2)·h); Kuhn n ×
the rotated icosphere(2); the gmsh box (h 0.1, needs gmsh) cut by z = 0.546875, then x =
0.421875 (``recut``), then y = 0.640625. Per case: the registration (``predicates.intersect``),
the split (``res.split()``), the conforming tetrahedralization (``sm.tetrahedralize()``; for
the later planes ``recut``, which runs its own registration), best of ``--repeat``; a
refusal is reported with its cell count.

    PYTHONPATH=. python3 benchmarks/conform_cases_bench.py [--n 16] [--repeat 1] [--json F]
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

from timing import best  # benchmarks/timing.py (this script's folder)

import predicates
from predicates.portable import rotate, rotation
from predicates.registration.examples import cube_grid, icosphere

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "support"))
from cut_cases import axis_plane as plane, disc_crack as disc, gmsh_box_in_box  # noqa: E402


def _conform(f):
    """f() or the refusal (:class:`NotConforming`) as a string."""
    from predicates.registration.split.conform import NotConforming

    try:
        return f()
    except NotConforming as e:
        return str(e)


def one_shot(name: str, P, C, Q, K, repeat: int) -> dict:
    res, t_reg = best(lambda: predicates.intersect(P, C, Q, K), repeat)
    sm, t_split = best(res.split, repeat)
    cm, t_conf = best(lambda: _conform(sm.tetrahedralize), repeat)
    row = {"case": name, "registration_s": t_reg, "split_s": t_split, "conforming_s": t_conf,
           "conforming_over_registration": t_conf / t_reg}
    return row | (cm.summary() if not isinstance(cm, str) else {"refused": cm[:160]})


def progressive(repeat: int) -> list:
    from predicates.registration.split.progressive import recut

    P, C, _, _ = gmsh_box_in_box(0.1)
    planes = [plane(2, 0.546875), plane(0, 0.421875), plane(1, 0.640625)]
    rows = [one_shot("gmsh box × plane 1", P, C, *planes[0], repeat)]
    cm = predicates.intersect(P, C, *planes[0]).split().tetrahedralize()
    for k, (Q, K) in enumerate(planes[1:], start=2):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res, t_reg = best(lambda: predicates.intersect(cm.points, cm.cells, Q, K), repeat)
            nxt, t = best(lambda: _conform(lambda: recut(cm, Q, K)), repeat)
        row = {"case": f"gmsh box, then plane {k} (recut)", "registration_s": t_reg,
               "recut_s": t, "recut_over_registration": t / t_reg}
        if isinstance(nxt, str):
            rows.append(row | {"refused": nxt[:160]})
            break
        rows.append(row | nxt.summary())
        cm = nxt
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--json")
    ap.add_argument("--no-gmsh", action="store_true")
    a = ap.parse_args()
    P, C = cube_grid(a.n)
    h = 1.0 / a.n
    centre = (0.5 + 0.3 * h, 0.5 + 0.2 * h, 0.5 + 0.1 * h)
    S, T = icosphere(2)
    S = rotate(S - 0.5, rotation(3, 3)) + 0.5
    rows = [one_shot(f"Kuhn {a.n} × disc R = {r} h", P, C, *disc(r * h, centre), a.repeat)
            for r in (0.5, 1.2, 3.0)]
    inside = (0.5 + 0.62 * h, 0.5 + 0.35 * h, 0.5 + 0.2 * h)  # in one cell, off its centre
    rows.append(one_shot(f"Kuhn {a.n} × disc R = 0.05 h inside one cell", P, C,
                         *disc(0.05 * h, inside), a.repeat))
    rows.append(one_shot(f"Kuhn {a.n} × rotated icosphere(2)", P, C, S, T, a.repeat))
    if not a.no_gmsh:
        rows += progressive(a.repeat)
    for r in rows:
        print(json.dumps({k: (round(v, 3) if isinstance(v, float) else v)
                          for k, v in r.items()}))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
