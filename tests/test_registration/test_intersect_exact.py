"""Exact consistency of the registration (paper section 3, eq. (1)) on every example and
on randomly rotated, rescaled, translated and jittered copies: every pair without a
registered sub-pair agrees with exact arithmetic through the T−/T+ brackets, at every
level (see tests/support/shared_cases.py for the oracle). FPERR_LONG=1 runs more and
larger cases."""
from __future__ import annotations

import os
import zlib

import numpy as np
import pytest

import predicates
from predicates.registration.examples import example
from shared_cases import check_exact, transformed

LONG = os.environ.get("FPERR_LONG") == "1"

CASES = [("circle", 6, {"segments": 24}), ("circle", 5, {"segments": 7, "radius": 0.5}),
         ("diagonal", 4, {}), ("diagonal", 6, {"step": 3}), ("zigzag", 4, {}),
         ("zigzag", 8, {"dx": 2, "dy": 6}),
         ("sphere", 3, {"subdivisions": 1}), ("plane", 3, {}), ("plane", 2, {"k": 0}),
         ("plane_offset", 3, {}), ("plane_offset", 4, {"k": 1})]
if LONG:
    CASES += [("circle", 12, {"segments": 100}), ("sphere", 5, {"subdivisions": 2}),
              ("plane", 6, {}), ("plane_offset", 6, {}), ("zigzag", 12, {"dx": 3, "dy": 3})]


def _id(case):
    name, n, kw = case
    return f"{name}-{n}-" + "-".join(f"{k}{v}" for k, v in kw.items())


@pytest.mark.parametrize("case", CASES, ids=[_id(c) for c in CASES])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_examples_agree_with_exact_arithmetic(case, dtype):
    name, n, kw = case
    ex = example(name, n, **kw)
    res = predicates.intersect(*ex["sim"], *ex["cut"], dtype=dtype)
    stats = check_exact(res)
    assert stats["registered"] == res.total


SEEDS = range(12 if LONG else 3)


@pytest.mark.parametrize("case", CASES, ids=[_id(c) for c in CASES])
@pytest.mark.parametrize("seed", SEEDS)
def test_random_copies_agree_with_exact_arithmetic(case, seed):
    name, n, kw = case
    rng = np.random.default_rng([seed, zlib.crc32(_id(case).encode())])
    args = transformed(example(name, n, **kw), rng)
    res = predicates.intersect(*args)
    check_exact(res)


@pytest.mark.parametrize("case", [c for c in CASES if c[0] in ("diagonal", "plane_offset",
                                                               "zigzag", "plane")],
                         ids=_id)
def test_near_degenerate_copies_small_jitter(case):
    """Jitter of 0.1–2 τ on every vertex: the pairs straddle the tolerances."""
    name, n, kw = case
    rng = np.random.default_rng(7)
    res = predicates.intersect(*transformed(example(name, n, **kw), rng, (0.1, 2.0), 1.0))
    check_exact(res)


def test_float32_random_copy():
    rng = np.random.default_rng(3)
    args = transformed(example("sphere", 3, subdivisions=1), rng)
    args = [a.astype(np.float32) if a.dtype.kind == "f" else a for a in args]
    res = predicates.intersect(*args, dtype=np.float32)
    assert not res.rounded_inputs
    check_exact(res)
