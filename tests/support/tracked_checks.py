"""Checks shared by the Tracked state tests: a quantity's state as a tuple, and the
exactness of state arithmetic (no floats in c, p, a, b)."""
from __future__ import annotations

import sympy


def state(x):
    st_ = x.state
    return (st_.c, st_.p, st_.n, st_.a, st_.b, st_.r)


def assert_exact(x):
    """State arithmetic is exact: no floats anywhere in c, p, a, b."""
    for v in (x.c, x.p, x.a, x.b):
        assert isinstance(v, sympy.Basic), v
        assert not v.has(sympy.Float), v
