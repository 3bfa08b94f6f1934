"""Stage 1's compiled pass (predicates.compiled.stage1.owned_levels) against a plain
loop of the box test, face by face, on runs whose cutting cells all pass (the run's
envelope decides: every pair written without its tests), none passes (skipped), or
some do — with NaN and infinite bounds on both sides (docs/design.md, "Compiled
candidate chain"; benchmarks/README.md, "s22-w1")."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")


def _reference(T, C, boxes_c, face_boxes, spec):
    """Per level, (f, c) for every run of equal T, every face T owns (its list's
    order), every pair of the run in order, when the exact per-axis test passes."""
    lo_c, hi_c = boxes_c
    out = []
    for (_, start, faces, _, pad), (lo, hi) in zip(spec, face_boxes):
        f_out, c_out = [], []
        q0 = 0
        while q0 < len(T):
            q1 = q0 + 1
            while q1 < len(T) and T[q1] == T[q0]:
                q1 += 1
            t = T[q0]
            for f in faces[start[t]:start[t + 1]]:
                for q in range(q0, q1):
                    c = C[q]
                    if all((lo_c[ax, c] - hi[f, ax] <= pad) and (lo[f, ax] - hi_c[ax, c] <= pad)
                           for ax in range(lo_c.shape[0])):
                        f_out.append(int(f))
                        c_out.append(int(c))
            q0 = q1
        out.append((f_out, c_out))
    return out


@pytest.mark.parametrize("bad", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize("d", [2, 3])
def test_owned_levels_every_none_and_some(seed, d, bad):
    """Runs of cutting cells drawn from a pool that meets every face (huge boxes), one
    that meets none (far boxes), both, or both and near ones: owned_levels' pairs are the
    plain loop's, in its order; ``bad``: NaN and ±inf bounds in cutting boxes of every
    pool and in the points (a NaN makes the envelope's answers False: tested pairs)."""
    from predicates.compiled.boxtest import owned_lists_of
    from predicates.compiled.stage1 import owned_levels
    from predicates.registration.levels.complex import Complex
    from predicates.registration.spatial.boxes import boxes_of

    rng = np.random.default_rng(seed)
    P = rng.integers(-2, 3, size=(30, d)) * 0.5
    P[rng.random(P.shape) < 0.2] = -0.0
    if bad:
        P[7, 1] = np.nan
        P[9, 0] = np.inf
    cx = Complex(np.array([rng.choice(30, d + 1, replace=False) for _ in range(40)]), 30)
    cells = cx.S[d]
    n_c = 30
    lo_c = rng.integers(-3, 3, size=(d, n_c)) * 0.5  # 0-9 near, 10-19 huge, 20-29 far
    hi_c = lo_c + rng.integers(0, 3, size=(d, n_c)) * 0.5
    lo_c[:, 10:20], hi_c[:, 10:20] = -10.0, 10.0
    lo_c[:, 20:], hi_c[:, 20:] = 100.0, 101.0
    if bad:
        lo_c[0, 3] = hi_c[1, 13] = np.nan
        lo_c[1, 14], hi_c[0, 24] = -np.inf, np.inf
        lo_c[0, 25] = np.nan
    pools = [np.arange(10, 20), np.arange(20, 30), np.arange(n_c), np.arange(10, 30)]
    T, C = [], []
    for t in np.sort(rng.choice(len(cells), 25, replace=False)):
        for _ in range(rng.integers(1, 3)):  # (a repeated T: one longer run)
            run = rng.choice(pools[rng.integers(0, 4)], rng.integers(1, 6))
            T += [t] * len(run)
            C += run.tolist()
    T, C = np.array(T), np.array(C)
    spec, face_boxes = [], []
    for i, pad in zip(range(d), (0.0, 0.25, 0.5)):
        start, faces, _, cols = owned_lists_of(cx.face(d, i), len(cx.S[i]), columns=True)
        spec.append((i, start, faces, cols, pad))
        face_boxes.append(boxes_of(P, cx.S[i]))
    want = _reference(T, C, (lo_c, hi_c), face_boxes, spec)
    got = owned_levels(T, C, (lo_c, hi_c), P, cells, spec)
    assert sum(len(f) for f, _ in want) > 0
    for (f, c), (wf, wc) in zip(got, want):
        assert f.tolist() == wf and c.tolist() == wc
