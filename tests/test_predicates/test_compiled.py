"""The compiled candidate chain (predicates.compiled) is bit-identical to numpy batch mode.

* lane by lane, every predicate, float64 and float32, on adversarial near-degenerate
  configurations (tests/support/geometry_constructions.construct: probes at the tolerances'
  thresholds, collinear / coplanar / coincident points) drawn by hypothesis, with the
  robust tolerances and with zero tolerances (the naive baseline's exact sign tests):
  the same hits and bitwise-equal weights;
* the generated code contains no fused multiply-add and no fast-math flag (LLVM IR and
  machine code of both dtypes), so each operation rounds once, as numpy's ufuncs do;
* a registration gives bitwise-identical results with and without the accelerator, and
  ``res.timings["accelerated"]`` says which ran (``FPERR_ACCELERATE=0``, ``accelerate=``).
"""
from __future__ import annotations

import re
import warnings
import zlib
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("numba")

import fperr  # noqa: E402
import predicates  # noqa: E402
from geometry_cases import DataSource, RngSource, Units, place  # noqa: E402
from geometry_constructions import construct  # noqa: E402
from geometry_exact import frac  # noqa: E402
from predicates import compiled  # noqa: E402
from predicates.compiled.build import INLINE_OPTIONS, JIT_OPTIONS, source  # noqa: E402
from predicates.compiled.chain import run_predicate  # noqa: E402
from predicates.registration import examples  # noqa: E402

PREDICATES = [p for d in (2, 3) for p in predicates.ALL[d]]
PRED_IDS = [f"{p.dim}d-{p.name}" for p in PREDICATES]
DTYPES = (np.float64, np.float32)


def _configs(pred, tol, src, n, bits, offset=0.0):
    u, L = Units.of(tol), frac(tol.L)
    out = []
    while len(out) < n:
        with np.errstate(all="ignore"):
            cfg = place(construct(pred.name, src, u), Fraction(offset) * L, L, bits)
        if cfg is not None:
            out.append(cfg)
    return out


def _compare(pred, configs, tol, dtype, rng):
    """numpy batch vs compiled chain on the same lanes (gathered through shuffled
    vertex tables): identical hits, bitwise-identical weights. Returns the hits."""
    arrs = [np.array([[float(c) for c in cfg[i]] for cfg in configs], dtype=dtype)
            for i in range(len(configs[0]))]
    hit, w = pred(*arrs, tol)
    n, n1, d = len(configs), len(pred.sim), pred.dim
    sides = []
    for pts in (arrs[:n1], arrs[n1:]):  # each primitive's points in a shuffled table
        k = len(pts)
        perm = rng.permutation(n * k)
        P = np.empty((n * k, d), dtype=dtype)
        P[perm] = np.stack(pts, axis=1).reshape(n * k, d)
        R = perm.reshape(n, k).astype(np.int32)
        order = rng.permutation(n)
        table = np.empty_like(R)
        table[order] = R
        sides.append((P, table, order.astype(np.int64)))
    pos, wc = run_predicate(pred, *sides, tol)
    assert np.array_equal(pos, np.flatnonzero(hit)), f"{pred.name}: hits differ"
    assert wc.dtype == w.dtype
    u = np.uint64 if dtype == np.float64 else np.uint32
    assert np.array_equal(wc.view(u), w[hit].view(u)), f"{pred.name}: weights differ"
    # the fused kernel's vectorized lanes (emit.fused_lines) on the same lanes, three
    # times over: full sets of 256 lanes and a last partial one
    first, wf = _fused_hits(pred, sides, tol, dtype, 3)
    assert np.array_equal(first, np.tile(sides[0][2], 3)[np.tile(hit, 3)]), pred.name
    assert np.array_equal(wf.view(u), np.tile(w[hit], (3, 1)).view(u)), pred.name
    return int(hit.sum())


def _fused_hits(pred, sides, tol, dtype, times):
    """The fused kernel on the lanes (I1[q], I2[q]) of ``sides`` repeated ``times``:
    every pair its own stage-1 pair (the cutting cell itself), every box test passed
    (pad = inf), no suppression flags. Returns (first ids of the hits, weights)."""
    from predicates.compiled.build import kernel
    from predicates.compiled.chain import _tolerance_array

    (P1, R1, I1), (P2, R2, I2) = sides
    run, names = kernel(pred, np.dtype(dtype).name, None, "fused")
    tv = _tolerance_array(pred, names, tol, np.dtype(dtype))
    F, C = np.tile(I1, times), np.tile(I2, times)
    n = len(F)
    out_s, out_c, maybe_s, maybe_c = (np.empty(n, np.int64) for _ in range(4))
    out_w = np.empty((n, max(1, len(pred.weight_names))), dtype)
    counts, no = np.zeros(3, np.int64), np.zeros(1, bool)
    # the cutting faces' boxes as rows, as the registration makes them: a vertex's
    # lane reads its point from its row (emit._cut_points)
    from predicates.compiled.boxtest import boxes
    from predicates.compiled.chain import box_rows

    lo, hi = boxes(P2, R2)
    box = box_rows(lo.T, hi.T)
    run(F, C, np.zeros(2, np.int64), np.zeros(2, np.int64), False, np.inf, P1, R1, box,
        no, no, False, False, P1, R1, P2, R2, tv, out_s, out_c, out_w, maybe_s,
        maybe_c, counts)
    assert counts[0] == n and counts[2] == 0
    return out_s[:counts[1]], out_w[:counts[1], :len(pred.weight_names)]


@pytest.mark.parametrize("dtype", DTYPES, ids=["float64", "float32"])
@pytest.mark.parametrize("pred", PREDICATES, ids=PRED_IDS)
def test_lanes_identical_seeded(pred, dtype):
    """A few hundred adversarial lanes per predicate and dtype, at several scales and
    offsets, with the robust and the zero tolerances; the hits must include some."""
    rng = np.random.default_rng(zlib.crc32(pred.name.encode()) + pred.dim)
    bits = 53 if dtype == np.float64 else 24
    hits = 0
    for scale, offset in (((1.0, 1.0), 0.0), ((0.75, 0.0), -0.5), ((3.0, 0.25), 3.0)):
        tol = predicates.tolerances(pred.dim, *scale, dtype=dtype)
        configs = _configs(pred, tol, RngSource(rng), 120, bits, offset)
        hits += _compare(pred, configs, tol, dtype, rng)
        _compare(pred, configs, tol.scaled(dtype(0)), dtype, rng)
    assert hits >= 5, "the comparison must include hits"


@pytest.mark.parametrize("dtype", DTYPES, ids=["float64", "float32"])
@pytest.mark.parametrize("pred", PREDICATES, ids=PRED_IDS)
@settings(max_examples=max(10, settings.default.max_examples // 8), deadline=None,
          suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_lanes_identical_hypothesis(pred, dtype, data):
    """hypothesis draws the near-degenerate configurations (and shrinks a failure)."""
    bits = 53 if dtype == np.float64 else 24
    tol = predicates.tolerances(pred.dim, 1.0, data.draw(st.sampled_from([0.0, 0.5, 1.0])),
                                dtype=dtype)
    configs = _configs(pred, tol, DataSource(data), 12, bits)
    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    _compare(pred, configs, tol, dtype, rng)


_FMA_ASM = re.compile(r"\bv?f(n)?m(add|sub)\d|\bvfmaddsub|\bvfmsubadd", re.I)
_FMA_IR = re.compile(r"@llvm\.(fma|fmuladd)|\bf(add|sub|mul|div|neg|cmp)\s+(fast|contract|"
                     r"reassoc|afn|arcp|nnan|ninf|nsz)\b")


@pytest.mark.parametrize("pred", PREDICATES, ids=PRED_IDS)
def test_no_fma_no_fast_math(pred):
    """Each kernel, compiled here without the disk cache, for both dtypes: no fma or
    fmuladd intrinsic and no fast-math flag in the LLVM IR, no FMA instruction in the
    machine code (this CPU has FMA: the compiler would use it if allowed)."""
    text = source(pred)
    for opts in (JIT_OPTIONS, INLINE_OPTIONS):
        text = text.replace(f"@njit(**{opts!r})", f"@njit(**{dict(opts, cache=False)!r})")
    ns: dict = {}
    exec(compile(text, f"<{pred.name}>", "exec"), ns)
    d, n1 = pred.dim, len(pred.sim)
    for dt in DTYPES:
        fn = ns[f"chain_{np.dtype(dt).name}"]
        assert fn.targetoptions.get("fastmath") in (False, None)
        P = np.zeros((1, d), dt)
        R1, R2 = np.zeros((1, n1), np.int64), np.zeros((1, len(pred.points) - n1), np.int64)
        I = np.zeros(1, np.int64)
        fn(P, R1, I, P, R2, I, np.zeros(8, dt), np.zeros(1, np.int64),
           np.zeros((1, max(1, len(pred.weight_names))), dt))
        # the fused chain too, with its box test written out in it (emit.fused_lines)
        fu = ns[f"fused_{np.dtype(dt).name}"]
        one, no, w = np.zeros(1, np.int64), np.zeros(1, bool), len(pred.weight_names)
        box = np.zeros((1, 2 * d))  # the cutting faces' boxes as rows
        fu(one, one, np.zeros(2, np.int64), one, False, 0.0, P, R1, box, no, no,
           False, False, P, R1, P, R2, np.zeros(8, dt), one, one,
           np.zeros((1, max(1, w)), dt), one, one, np.zeros(3, np.int64))
        for f in (fn, fu):
            for sig in f.signatures:
                ir, asm = f.inspect_llvm(sig), f.inspect_asm(sig)
                assert not _FMA_IR.search(ir), f"{pred.name} {dt}: {_FMA_IR.search(ir)[0]}"
                assert not _FMA_ASM.search(asm), f"{pred.name} {dt}: {_FMA_ASM.search(asm)[0]}"


def _same(a, b):
    assert a.kinds == b.kinds
    for k in a.kinds:
        pa, pb = a[k], b[k]
        for x, y in ((pa.sim, pb.sim), (pa.cut, pb.cut), (pa.sim_weights, pb.sim_weights),
                     (pa.cut_weights, pb.cut_weights)):
            assert x.dtype == y.dtype and x.shape == y.shape
            assert x.tobytes() == y.tobytes(), k
        assert (pa.candidates, pa.suppressed) == (pb.candidates, pb.suppressed)


@pytest.mark.parametrize("dtype", DTYPES, ids=["float64", "float32"])
@pytest.mark.parametrize("case", ["cube-sphere", "square-circle", "cube-plane"])
def test_registration_identical(case, dtype):
    """Whole registrations, array by array; the plane through grid vertices suppresses
    thousands of pairs (the compiled suppression look-up, loop._blocked)."""
    sim, cut = {"cube-sphere": (examples.cube_grid(6), examples.icosphere(2)),
                "square-circle": (examples.square_grid(24), examples.circle_polygon(200)),
                "cube-plane": (examples.cube_grid(6), examples.grid_plane(6))}[case]
    with warnings.catch_warnings():  # float32: coarse-resolution warnings
        warnings.simplefilter("ignore", fperr.ResolutionWarning)
        a = predicates.intersect(*sim, *cut, dtype=dtype, accelerate=False)
        b = predicates.intersect(*sim, *cut, dtype=dtype, accelerate=True)
    assert a.timings["accelerated"] is False and b.timings["accelerated"] is True
    assert a.total > 0
    _same(a, b)


def test_switch(monkeypatch):
    monkeypatch.setattr(compiled, "_loaded", False)
    monkeypatch.setenv("FPERR_ACCELERATE", "0")
    assert compiled.resolve(None) is False
    assert compiled.resolve(True) is True
    monkeypatch.setenv("FPERR_ACCELERATE", "1")
    assert compiled.resolve(None) is True and compiled.resolve(False) is False
    with pytest.raises(TypeError):
        compiled.resolve("yes")
    monkeypatch.setattr(compiled, "available", lambda: False)
    assert compiled.resolve(None) is False
    with pytest.raises(ImportError, match="fast"):
        compiled.resolve(True)


def test_auto_follows_the_run_size(monkeypatch):
    """Unset FPERR_ACCELERATE: the compiled chain from AUTO_CELLS cells on (loading it
    costs more than it saves below), or once it ran in this process; the result says
    which ran, and both give the same bits."""
    monkeypatch.delenv("FPERR_ACCELERATE", raising=False)
    monkeypatch.setattr(compiled, "_loaded", False)
    assert compiled.resolve(None) is None  # decided once the cells are counted
    assert compiled.resolve(None, cells=compiled.AUTO_CELLS - 1) is False
    assert compiled.resolve(None, cells=float("nan")) is True  # unknown: a large run
    monkeypatch.setattr(compiled, "_loaded", False)
    sim, cut = examples.cube_grid(6), examples.icosphere(2)
    small = predicates.intersect(*sim, *cut)
    assert small.timings["accelerated"] is False
    monkeypatch.setattr(compiled, "AUTO_CELLS", len(sim[1]) + len(cut[1]))
    large = predicates.intersect(*sim, *cut)
    assert large.timings["accelerated"] is True
    _same(small, large)
    monkeypatch.setattr(compiled, "AUTO_CELLS", 10**12)  # loaded now: stays compiled
    assert predicates.intersect(*sim, *cut).timings["accelerated"] is True


def test_trace_refuses_if_on_a_number():
    from predicates.core import predicate
    from predicates.compiled.trace import trace

    @predicate(dim=2, points="AB")
    def branchy(ctx, A, B, tol):
        if A[0] > B[0]:
            return ctx.miss()
        return ctx.hit(())

    with pytest.raises(TypeError, match="ctx.reject"):
        trace(branchy)


def test_fma_check_detects_fma():
    """The checks above would see an FMA: the same expression compiled with fast-math
    contracts to one on this CPU (skipped where the CPU has none)."""
    from numba import njit

    def f(a, b, c):
        return a * b + c

    fast, strict = njit(fastmath=True)(f), njit(fastmath=False)(f)
    fast(1.0, 2.0, 3.0), strict(1.0, 2.0, 3.0)
    sig = fast.signatures[0]
    assert not _FMA_ASM.search(strict.inspect_asm(sig))
    assert _FMA_IR.search(fast.inspect_llvm(sig))
    if "fma" not in open("/proc/cpuinfo").read().split():
        pytest.skip("no FMA on this CPU")
    assert _FMA_ASM.search(fast.inspect_asm(sig))


@pytest.mark.parametrize("seed", range(4))
def test_box_pairs_compiled_join_identical(seed):
    """The broad phase compiled yields the same pairs, each once, crowded cells
    (refined grids) and multi-cell boxes included (in another order on a dense grid:
    its bucket-and-join pass reports them by a box; the registration sorts its output)."""
    from predicates.registration.spatial.broadphase import box_pairs

    rng = np.random.default_rng(seed)
    n, d = 3000, 2 + seed % 2
    lo_a = rng.random((n, d)) * np.where(rng.random((n, 1)) < 0.3, 0.01, 1.0)
    hi_a = lo_a + rng.random((n, d)) * 0.05
    lo_b = rng.random((n // 2, d))
    hi_b = lo_b + rng.random((n // 2, d)) * rng.choice([0.001, 0.2], size=(n // 2, 1))
    for pad in (0.0, 1e-3):
        a = list(box_pairs(lo_a, hi_a, lo_b, hi_b, pad, chunk=1 << 12))
        b = list(box_pairs(lo_a, hi_a, lo_b, hi_b, pad, chunk=1 << 12, accelerate=True))
        ia, ib = (np.concatenate([p[k] for p in a]) for k in (0, 1))
        ja, jb = (np.concatenate([p[k] for p in b]) for k in (0, 1))
        want, got = np.lexsort((ib, ia)), np.lexsort((jb, ja))
        assert np.array_equal(ia[want], ja[got]) and np.array_equal(ib[want], jb[got])
        assert len(ia) > 100 and len(set(zip(ja.tolist(), jb.tolist()))) == len(ja)



@pytest.mark.parametrize("dtype", [np.int32, np.int64])
def test_renumbered_is_cumsum_take(dtype):
    """cell_pairs' compiled renumbering (boxtest.renumbered) gives the mask of the
    values present and ``(np.cumsum(keep) - 1).take(ids)`` in a fresh array, the ids
    untouched: repeats, gaps, values at both ends, no ids at all; ascending ids (its
    one-pass route), and ascending but for the last one (the general route after it)."""
    from predicates.compiled.boxtest import renumbered

    rng = np.random.default_rng(5)
    for n, m in ((1, 3), (50, 400), (10_000, 2_000), (7, 0)):
        for order in ("random", "ascending", "last descends"):
            ids = rng.integers(0, n, m).astype(dtype)
            if m:
                ids[:2] = 0, n - 1
            if order != "random":
                ids.sort()
                if order == "last descends" and m > 2 and n > 1:
                    ids[-1] = ids[-2] - 1 if ids[-2] else 1
            keep = np.zeros(n, dtype=bool)
            keep[ids] = True
            want = (np.cumsum(keep) - 1).take(ids)
            before = ids.copy()
            got_keep, got = renumbered(ids, n)
            assert np.array_equal(got_keep, keep) and np.array_equal(ids, before)
            assert got.dtype == dtype and np.array_equal(got, want)
            assert not m or got.max() == keep.sum() - 1  # the kept ones are dense


def test_triangle_boxes_identical():
    """3D triangles' boxes, compiled (ids read once a row, unsigned) and by numpy: the same
    bytes, with signed zeros, NaN and infinities, float32 and float64 points."""
    from predicates.registration.spatial.blocks import Blocks
    from predicates.registration.spatial.boxes import boxes_of

    rng = np.random.default_rng(11)
    P = rng.choice([-0.0, 0.0, 0.25, -0.5, np.nan, np.inf, -np.inf], size=(300, 3))
    P[150:] = rng.random((150, 3))
    for cells in (rng.integers(0, 300, size=(2000, 3)),
                  rng.integers(0, 300, size=(2000, 3)).astype(np.int32)):
        for pts in (P.astype(np.float32), P):
            lo, hi = boxes_of(pts, cells)
            lo2, hi2 = boxes_of(pts, cells, Blocks(accelerate=True))
            assert lo.tobytes() == lo2.tobytes() and hi.tobytes() == hi2.tobytes()


def test_cell_passes_identical():
    """The plan's compiled per-cell passes (Blocks(accelerate=True)) give the numpy
    passes' values: boxes (signed zeros included), cell indices, coverage, look-ups,
    near_flags and tighten_flags, serial and on a thread pool with tiny blocks."""
    from concurrent.futures import ThreadPoolExecutor

    from predicates.registration.spatial import boxgrid, gridsums
    from predicates.registration.spatial.blocks import SERIAL, Blocks
    from predicates.registration.spatial.boxes import boxes_of
    from predicates.registration.spatial.broadphase import near_flags, tighten_flags

    rng = np.random.default_rng(5)
    for d in (2, 3):
        P = rng.choice([-0.0, 0.0, 0.25, -0.5, 1.0], size=(400, d))
        P[200:] = rng.random((200, d))
        cells = rng.integers(0, 400, size=(3000, d + 1))
        with ThreadPoolExecutor(2) as pool:
            for fast in (Blocks(accelerate=True), Blocks(pool, 2, block=7, accelerate=True)):
                for pts in (P.astype(np.float32), P):
                    lo, hi = boxes_of(pts, cells)
                    lo2, hi2 = boxes_of(pts, cells, fast)
                    assert lo.tobytes() == lo2.tobytes() and hi.tobytes() == hi2.tobytes()
                G = np.array([7, 5, 3][:d], dtype=np.int64)
                origin, h = np.full(d, -0.3), 0.17
                i0 = boxgrid.cell_index(lo, origin, h, G)
                i1 = boxgrid.cell_index(hi, origin, h, G)
                assert np.array_equal(i0, boxgrid.cell_index(lo, origin, h, G, fast))
                cov = gridsums.coverage(i0, i1, G)
                assert np.array_equal(cov, gridsums.coverage(i0, i1, G, fast))
                occ = gridsums.occupancy(i0[:50], i1[:50], G)
                assert np.array_equal(gridsums.any_in(occ, i0, i1, G),
                                      gridsums.any_in(occ, i0, i1, G, fast))
                for pad in (0.0, 0.01):
                    args = (lo[:1500], hi[:1500], lo[1500:], hi[1500:], pad)
                    for f in (near_flags, ):
                        a, b = f(*args, blocks=SERIAL), f(*args, blocks=fast)
                        assert all(np.array_equal(x, y) for x, y in zip(a, b))
                    a, b = tighten_flags(*args), tighten_flags(*args, blocks=fast)
                    assert all(np.array_equal(x, y) for x, y in zip(a, b))


@pytest.mark.parametrize("d", [2, 3])
def test_shortest_edge_identical(d):
    from predicates.registration.plan.resolution import shortest_edge
    from predicates.registration.spatial.blocks import Blocks

    rng = np.random.default_rng(d)
    P = rng.random((500, d)) * 2.0 ** rng.integers(-30, 30)
    cells = np.array([rng.choice(500, d + 1, replace=False) for _ in range(4000)])
    mask = rng.random(4000) < 0.7
    a = shortest_edge(P, cells, mask)
    assert a == shortest_edge(P, cells, mask, Blocks(accelerate=True)) and a > 0


@pytest.mark.parametrize("k", [3, 4])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("scale", [0, -30, 30, -1070, 1022])
def test_shortest_edge_from_boxes_identical(k, dtype, scale):
    """The report's shortest edge read from the points as given with the largest
    |coordinate| from the cells' boxes (edgerows.least_square_rows) is the renumbered,
    scaled copy's value, for tetrahedra and triangles, float32 and float64, at scales
    where 2^-shift is normal and where times_pow2 takes ldexp (the copy's path)."""
    from concurrent.futures import ThreadPoolExecutor

    from predicates.registration.plan.edges import edge_summary, shortest_edge
    from predicates.registration.spatial import blocks as B
    from predicates.registration.spatial.boxes import boxes_of

    rng = np.random.default_rng(k + abs(scale))
    if dtype == np.float32:  # float32's range: subnormal and largest binades
        scale = {-1070: -140, 1022: 120}.get(scale, scale)
    P = ((rng.random((300, 3)) - 0.5) * 2.0 ** scale).astype(dtype)
    cells = np.array([rng.choice(300, k, replace=False) for _ in range(2000)])
    mask = rng.random(2000) < 0.6
    fast = B.Blocks(accelerate=True)
    ref = shortest_edge(P, cells, mask, fast)
    assert ref == shortest_edge(P, cells, mask) and ref >= 0
    lo, hi = boxes_of(P, cells[mask], B.SERIAL)
    old = B.MIN_SPAN
    B.MIN_SPAN = 100  # several spans on the pool: the minimum of their minima
    try:
        with ThreadPoolExecutor(2) as pool:
            for bl in (fast, B.Blocks(pool, 2, accelerate=True)):
                assert shortest_edge(P, cells, mask, bl, (lo, hi)) == ref
                # points not C-ordered: the copy's path, the same value
                assert shortest_edge(np.asfortranarray(P), cells, mask, bl, (lo, hi)) == ref
    finally:
        B.MIN_SPAN = old
    top, shift, _ = edge_summary(P, cells[mask])
    assert max(-float(lo.min()), float(hi.max())) == top  # the boxes' bound is the top


@pytest.mark.parametrize("width", [1, 3, 6])
def test_owned_lists_are_the_owned_table(width):
    """The compiled kernels' owned-face lists (boxtest.owned_lists, and owned_lists_of
    from the face map directly) hold each cell's owned faces of facepairs.owned_table,
    in its column order, and nothing else."""
    from predicates.compiled.boxtest import owned_lists, owned_lists_of
    from predicates.registration.levels.facepairs import owned_table

    rng = np.random.default_rng(width)
    F = rng.integers(0, 40, size=(60, width))
    tab = owned_table(F, 40)
    start, faces = owned_lists(tab)
    assert start[0] == 0 and start[-1] == len(faces) == int((tab >= 0).sum())
    for c, row in enumerate(tab.tolist()):
        assert faces[start[c]:start[c + 1]].tolist() == [g for g in row if g >= 0]
    assert owned_lists(tab)[1] is faces  # cached per table
    # straight from the face map, no table: the same owners and lists
    start2, faces2, widest = owned_lists_of(F, 40)
    assert np.array_equal(start2, start) and np.array_equal(faces2, faces)
    assert widest == int(np.diff(start).max())


def _runs_like_the_join(rng):
    """(T, C) in runs of equal T, as a structured mesh's join lists them: a run listing
    the same cutting cells as the one before (its boxes not copied again), a run of the
    same length with other cells, and two equal runs of 70 (the run buffer regrown)."""
    lens = rng.integers(1, 6, 20)
    lens[1::2] = lens[::2]
    lens[10] = lens[11] = 70
    parts = []
    for k, n in enumerate(lens):
        same = k % 2 == 1 and k % 4 != 3  # k % 4 == 3: the same length, other cells
        parts.append(parts[-1] if same else rng.integers(0, 25, n))
    return np.repeat(np.arange(20), lens), np.concatenate(parts)


@pytest.mark.parametrize("runs", ["random", "repeated"])
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("d", [2, 3])
def test_stage1_boxes_from_the_cells_keep_the_stored_boxes_pairs(seed, d, runs):
    """Stage 1 (stage1.owned_levels) folds each face's box from its cell's vertices at
    the face's column: on points with ties, signed zeros and NaNs, its pairs are
    exactly those of the numpy owned-table expansion and box test on boxes_of's stored
    boxes of the complex's faces, level by level (in its order: per run of pairs
    sharing a cell, face by face, each with the run's cutting cells in order), in 2D
    and 3D; also when runs repeat the previous run's cutting cells (whose copied boxes
    it reuses)."""
    from predicates.compiled.boxtest import owned_lists_of
    from predicates.compiled.stage1 import owned_levels
    from predicates.registration.levels.complex import Complex
    from predicates.registration.levels.facepairs import _owned, owned_table
    from predicates.registration.spatial.boxes import boxes_of
    from predicates.registration.spatial.broadphase import pair_test

    rng = np.random.default_rng(seed)
    P = rng.integers(-2, 3, size=(30, d)) * 0.5  # coarse: equal coordinates, touching
    P[rng.random(P.shape) < 0.2] = -0.0
    P[7, 1] = P[12, 0] = np.nan
    cx = Complex(np.array([rng.choice(30, d + 1, replace=False) for _ in range(40)]), 30)
    cells = cx.S[d]
    assert len(cells) >= 20
    lo_c = rng.integers(-3, 3, size=(d, 25)) * 0.5
    boxes_c = (lo_c, lo_c + rng.integers(0, 3, size=(d, 25)) * 0.5)
    T = np.sort(rng.integers(0, len(cells), 200))
    C = rng.integers(0, 25, 200)
    if runs == "repeated":
        T, C = _runs_like_the_join(rng)
    spec, want = [], []
    for i, pad in zip(range(d), (0.0, 0.25, 0.5)):  # vertices, edges (, triangles)
        F, R = cx.face(d, i), cx.S[i]
        start, faces, _, cols = owned_lists_of(F, len(R), columns=True)
        spec.append((i, start, faces, cols, pad))
        lo, hi = boxes_of(P, R)
        f, rows = _owned(owned_table(F, len(R)), T)
        keep = pair_test(pad, lo.T, hi.T, *boxes_c, f, C.take(rows))
        # the numpy order is (pair, face column); owned_levels' (run of T, face
        # column, pair) — T ascends
        tab = owned_table(F, len(R)).take(T, axis=0)
        col = np.flatnonzero(tab >= 0) % tab.shape[1]
        by_run = np.lexsort((rows[keep], col[keep], T.take(rows)[keep]))
        want.append((f[keep][by_run], C.take(rows)[keep][by_run]))
    got = owned_levels(T, C, boxes_c, P, cells, spec)
    assert len(got) == d and sum(len(f) for f, _ in want) > 0
    for (f, c), (wf, wc) in zip(got, want):
        assert f.tolist() == wf.tolist() and c.tolist() == wc.tolist()


def test_owned_lists_columns_are_the_faces_columns():
    """owned_lists_of's ``columns``: each listed face is its cell's entry at that
    column of the face map (what stage 1 folds its box from), the lists unchanged."""
    from predicates.compiled.boxtest import owned_lists_of

    rng = np.random.default_rng(3)
    F = rng.integers(0, 40, size=(60, 6))
    start, faces, widest, cols = owned_lists_of(F, 40, columns=True)
    assert cols.dtype == np.uint8 and len(cols) == len(faces)
    assert all(np.array_equal(a, b) for a, b in zip(owned_lists_of(F, 40), (start, faces)))
    cell = np.repeat(np.arange(len(F)), np.diff(start))
    assert np.array_equal(F[cell, cols], faces)
    assert len(owned_lists_of(F[:0], 40, columns=True)[3]) == 0
