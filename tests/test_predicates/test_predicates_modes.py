"""The number systems agree with each other on the same inputs.

* Python floats (scalar) and numpy float64 (batch) give identical results: the same hit
  and bitwise-equal weights, lane by lane — also when the batch is split into blocks and
  when a single point is broadcast against a batch;
* mpmath at 53 bits (round to nearest, like binary64) gives the same results as Python
  floats, and mpmath at 24 bits the same as numpy float32 batches (two independent
  implementations of the same correctly rounded arithmetic);
* lanes rejected early because of a zero-length edge (m = 0), a zero-area triangle or a
  flat tetrahedron raise no warning even with every numpy floating-point error turned
  into an exception, and come back as (False, zeros), while the other lanes of the same
  batch are unaffected;
* docs/custom-predicates.md runs as written (its code blocks are executed here, and
  their printed output must match the page).
"""
from __future__ import annotations

import contextlib
import io
import pathlib
import re
import struct
import warnings
import zlib
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fperr
import predicates
from geometry_cases import DataSource, RngSource, Units, place
from geometry_constructions import construct
from geometry_exact import frac
from predicates.core import Predicate

PREDICATES = [p for d in (2, 3) for p in predicates.ALL[d]]
PRED_IDS = [f"{p.dim}d-{p.name}" for p in PREDICATES]
DOC = pathlib.Path(__file__).resolve().parents[2] / "docs" / "custom-predicates.md"

SCALES = [(1.0, 1.0), (0.75, 0.0), (3.0, 0.25), (96.0, 32.0)]


def _configs(pred, tol, src, n, bits, offset=0.0):
    u = Units.of(tol)
    L = frac(tol.L)
    out = []
    while len(out) < n:
        with np.errstate(all="ignore"):
            cfg = place(construct(pred.name, src, u), Fraction(offset) * L, L, bits)
        if cfg is not None:
            out.append(cfg)
    return out


def _arrays(configs, dtype):
    return [np.array([[float(c) for c in cfg[i]] for cfg in configs], dtype=dtype)
            for i in range(len(configs[0]))]


def _bits64(x) -> int:
    return struct.unpack("<Q", struct.pack("<d", float(x)))[0]


def _bits32(x) -> int:
    return int(np.float32(x).view(np.uint32))


def _assert_same(pred, cfg, scalar, batch_hit, batch_w, bits=_bits64, what="batch"):
    h, w = scalar
    assert h == bool(batch_hit), f"{pred.name}: scalar hit {h} != {what} {batch_hit} at {cfg}"
    assert len(w) == len(batch_w)
    for a, b in zip(w, batch_w):
        assert bits(a) == bits(b), (f"{pred.name}: weights differ bitwise: scalar {a!r}, "
                                    f"{what} {b!r} at {cfg}")


def _scalar(pred, cfg, tol, ctx=None):
    pts = [tuple(float(c) for c in p) for p in cfg]
    return pred(*pts, tol, ctx=ctx) if ctx is not None else pred(*pts, tol)


# ---------------------------------------------------------------------------------
# scalar vs batch


@pytest.mark.parametrize("pred", PREDICATES, ids=PRED_IDS)
def test_scalar_and_batch_identical(pred, monkeypatch):
    """Same float64 inputs: identical hits and bitwise-identical weights, for one batch,
    for the same batch split into blocks of 7 lanes, and against mpmath at 53 bits."""
    rng = np.random.default_rng(zlib.crc32(pred.name.encode()) + pred.dim)
    src = RngSource(rng)
    mp53 = fperr.MpContext(53)
    n_hits = 0
    for scale, offset in zip(SCALES, (0.0, -0.5, 3.0, 64.0)):
        tol = predicates.tolerances(pred.dim, *scale, dtype=np.float64)
        tol_f = predicates.tolerances(pred.dim, *scale, dtype=float)
        tol_mp = predicates.tolerances(pred.dim, *scale, dtype="mp53")
        configs = _configs(pred, tol, src, 150, 53, offset)
        hit, w = pred(*_arrays(configs, np.float64), tol)
        monkeypatch.setattr(Predicate, "BLOCK", 7)
        hit7, w7 = pred(*_arrays(configs, np.float64), tol)
        monkeypatch.undo()
        assert np.array_equal(hit, hit7) and np.array_equal(w.view(np.uint64), w7.view(np.uint64))
        for k, cfg in enumerate(configs):
            scalar = _scalar(pred, cfg, tol_f)
            _assert_same(pred, cfg, scalar, hit[k], w[k])
            assert scalar == _scalar(pred, cfg, tol), "float vs np.float64 tolerances"
            if k % 5 == 0:  # mpmath is slow: a fifth of the lanes
                h_mp, w_mp = _scalar(pred, cfg, tol_mp, ctx=mp53)
                _assert_same(pred, cfg, scalar, h_mp, w_mp, what="mpmath-53")
            n_hits += scalar[0]
    assert n_hits >= 5, "the comparison must include hits"


@pytest.mark.parametrize("pred", PREDICATES, ids=PRED_IDS)
def test_float32_batch_matches_mpmath_24_bits(pred):
    """numpy float32 batches and mpmath at 24 bits: the same correctly rounded arithmetic,
    so identical hits and bitwise-identical weights (and a 1-lane batch equals its lane
    in a larger batch)."""
    rng = np.random.default_rng(zlib.crc32(pred.name.encode()) + 7 * pred.dim)
    src = RngSource(rng)
    mp24 = fperr.MpContext(24)
    for scale in SCALES[:2]:
        tol = predicates.tolerances(pred.dim, *scale, dtype=np.float32)
        tol_mp = predicates.tolerances(pred.dim, *scale, dtype="mp24")
        assert all(frac(tol.values[k]) == frac(tol_mp.values[k]) for k in tol.values)
        configs = _configs(pred, tol, src, 60, 24)
        arrs = _arrays(configs, np.float32)
        hit, w = pred(*arrs, tol)
        for k, cfg in enumerate(configs):
            h_mp, w_mp = _scalar(pred, cfg, tol_mp, ctx=mp24)
            _assert_same(pred, cfg, (h_mp, w_mp), hit[k], w[k], bits=_bits32)
            h1, w1 = pred(*[a[k:k + 1] for a in arrs], tol)
            assert h1[0] == hit[k] and np.array_equal(w1[0].view(np.uint32), w[k].view(np.uint32))


@pytest.mark.parametrize("pred", PREDICATES, ids=PRED_IDS)
@settings(max_examples=max(10, settings.default.max_examples // 8), deadline=None,
          suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_scalar_and_batch_identical_hypothesis(pred, data):
    scale = data.draw(st.sampled_from(SCALES), label="scale")
    tol = predicates.tolerances(pred.dim, *scale, dtype=np.float64)
    with np.errstate(all="ignore"):
        pts = construct(pred.name, DataSource(data), Units.of(tol))
    cfg = place(pts, Fraction(0), frac(tol.L), 53)
    if cfg is None:
        return
    hit, w = pred(*_arrays([cfg], np.float64), tol)
    _assert_same(pred, cfg, _scalar(pred, cfg, tol), hit[0], w[0])


def test_broadcast_single_point_against_batch():
    tol = predicates.tolerances(3, 1.0, 0.0)
    rng = np.random.default_rng(3)
    P, Q = rng.random((50, 3)), rng.random((50, 3))
    A, B, C = np.array([0.0, 0, 0.5]), np.array([1.0, 0, 0.5]), np.array([0.0, 1, 0.5])
    hit, w = predicates.d3.triangle_edge(A, B, C, P, Q, tol)
    rep = [np.repeat(X[None], 50, axis=0) for X in (A, B, C)]
    hit2, w2 = predicates.d3.triangle_edge(*rep, P, Q, tol)
    assert np.array_equal(hit, hit2) and np.array_equal(w, w2)
    assert hit.any() and not hit.all()


# ---------------------------------------------------------------------------------
# early-rejected lanes: no warnings, zeros


def _good_and_degenerate(dim, name):
    """(a configuration that hits, the same with a zero-length edge / zero area)."""
    if dim == 2:
        good = {"vertex_vertex": [(0.0, 0.0), (0.0, 0.0)],
                "edge_vertex": [(0.0, 0.0), (1.0, 0.0), (0.5, 0.0)],
                "edge_edge": [(0.0, 0.0), (1.0, 0.0), (0.5, -0.5), (0.5, 0.5)],
                "triangle_vertex": [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.25, 0.25)]}[name]
        bad = {"vertex_vertex": [(0.0, 0.0), (1.0, 0.0)],
               "edge_vertex": [(0.5, 0.5), (0.5, 0.5), (0.5, 0.5)],        # m = 0
               "edge_edge": [(0.5, 0.0), (0.5, 0.0), (0.5, 0.0), (0.5, 0.0)],
               "triangle_vertex": [(0.0, 0.0), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0)]}[name]
    else:
        good = {"vertex_vertex": [(0.0, 0, 0), (0.0, 0, 0)],
                "edge_vertex": [(0.0, 0, 0), (1.0, 0, 0), (0.5, 0, 0)],
                "edge_edge": [(0.0, 0, 0), (1.0, 0, 0), (0.5, -0.5, 0), (0.5, 0.5, 0)],
                "triangle_vertex": [(0.0, 0, 0), (1.0, 0, 0), (0.0, 1, 0), (0.25, 0.25, 0)],
                "triangle_edge": [(0.0, 0, 0), (1.0, 0, 0), (0.0, 1, 0), (0.25, 0.25, -1),
                                  (0.25, 0.25, 1)],
                "tetrahedron_vertex": [(0.0, 0, 0), (1.0, 0, 0), (0.0, 1, 0), (0.0, 0, 1),
                                       (0.2, 0.2, 0.2)]}[name]
        z = (0.5, 0.5, 0.5)
        bad = {"vertex_vertex": [(0.0, 0, 0), (1.0, 0, 0)],
               "edge_vertex": [z, z, z],                                  # m = 0
               "edge_edge": [z, z, z, z],                                 # m² = 0
               "triangle_vertex": [z, z, z, z],
               "triangle_edge": [z, z, z, z, z],
               "tetrahedron_vertex": [z, z, z, z, z]}[name]
    return good, bad


@pytest.mark.parametrize("dtype", (np.float64, np.float32))
@pytest.mark.parametrize("pred", PREDICATES, ids=PRED_IDS)
def test_rejected_lanes_raise_nothing_and_return_zeros(pred, dtype):
    good, bad = _good_and_degenerate(pred.dim, pred.name)
    tol = predicates.tolerances(pred.dim, 1.0, 1.0, dtype=dtype)
    # also degenerate shapes that survive longer: a zero-length edge next to a real one
    lanes = [good, bad, good, bad, bad]
    if pred.name == "edge_edge":
        lanes.append([good[0], good[1], good[2], good[2]])   # PQ of length 0
        lanes.append([good[0], good[0], good[2], good[3]])   # AB of length 0
    if pred.name in ("triangle_vertex", "triangle_edge", "tetrahedron_vertex"):
        lanes.append([good[0], good[0]] + list(good[2:]))    # a repeated vertex
    if pred.name == "triangle_edge":
        lanes.append(list(good[:3]) + [good[3], good[3]])    # PQ of length 0
    arrs = [np.array([lane[i] for lane in lanes], dtype=dtype) for i in range(len(good))]
    expected = [lane is good for lane in lanes]
    for block in (None, 2):
        with warnings.catch_warnings(), np.errstate(all="raise"):
            warnings.simplefilter("error")
            with contextlib.ExitStack() as stack:
                if block:
                    stack.enter_context(pytest.MonkeyPatch.context()).setattr(Predicate, "BLOCK", block)
                hit, w = pred(*arrs, tol)
        assert hit.tolist() == expected, (pred.name, hit)
        assert np.isfinite(w).all()
        assert (w[~hit] == 0).all()
        if w.shape[1]:
            assert (w[hit] > 0).all() and (w[hit] < 1).all()
    # every lane rejected at the first test: the run stops early, still zeros
    only_bad = [np.array([bad[i]] * 4, dtype=dtype) for i in range(len(bad))]
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        hit, w = pred(*only_bad, tol)
    assert not hit.any() and w.shape == (4, len(pred.weight_names)) and (w == 0).all()
    assert w.dtype == np.dtype(dtype)


# ---------------------------------------------------------------------------------
# the custom-predicate page runs as written


def test_custom_predicate_doc():
    text = DOC.read_text()
    blocks = re.findall(r"```(python|text)\n(.*?)```", text, re.S)
    assert sum(kind == "python" for kind, _ in blocks) >= 4
    env: dict = {"__name__": "custom_predicates_doc"}
    printed = None
    compared = 0
    for kind, body in blocks:
        if kind == "python":
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                exec(compile(body, str(DOC), "exec"), env)
            printed = buf.getvalue()
        else:
            assert printed is not None, "an output block must follow a code block"
            assert printed == body, f"docs/custom-predicates.md output drifted:\n{printed}"
            compared += 1
            printed = None
    assert compared >= 4
    # the page's claims: orient2d's determinant has the paper's bound 9εL², the
    # predicates run in every mode
    det = env["orient2d"].instrumented().quantities["det"]
    assert fperr.bounds(det).E_int == 9 and fperr.bounds(det).power == 2
    assert env["orient2d"]((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), env["tol"]) == (True, ())


# ---------------------------------------------------------------------------------
# the signatures users call

@pytest.mark.parametrize("pred", PREDICATES, ids=PRED_IDS)
def test_predicates_show_the_signature_a_user_calls(pred):
    """help()/inspect show the points, tol and the keyword ctx (not the source's leading
    ctx), derived from the source; the docstring states the return shapes."""
    import inspect

    sig = inspect.signature(pred)
    names = list(sig.parameters)
    assert names == [*pred.points, "tol", "ctx"]
    assert sig.parameters["ctx"].kind is inspect.Parameter.KEYWORD_ONLY
    assert all(sig.parameters[p].kind is inspect.Parameter.POSITIONAL_ONLY
               for p in (*pred.points, "tol"))
    assert "Returns ``(hit, weights)``" in pred.__doc__
    assert f"(..., {len(pred.weight_names)})" in pred.__doc__


def test_intersect_shows_named_typed_parameters():
    import inspect

    sig = inspect.signature(predicates.intersect)
    params = sig.parameters
    assert list(params)[:4] == ["sim", "cut", "cut_points", "cut_cells"]
    for name in ("dtype", "tolerance_scale", "refine_cut", "strict", "tolerances",
                 "sim_region", "cut_region", "progress", "partitions", "scheduler",
                 "timeout", "memory_limit", "chunk"):
        assert params[name].kind is inspect.Parameter.KEYWORD_ONLY, name
        assert params[name].annotation is not inspect.Parameter.empty, name
    assert sig.return_annotation == "IntersectionResult"
