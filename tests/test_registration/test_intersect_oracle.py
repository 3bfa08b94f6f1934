"""Sanity tests of the exact-arithmetic oracle for :func:`predicates.intersect`
(:func:`check_exact`, in tests/support/shared_cases.py)."""
import pytest

import predicates
from predicates.registration.examples import example
from shared_cases import check_exact, ee2, ee3, ev, te, tetv, tv2, tv3, vv


# -- sanity tests of the oracle itself -------------------------------------------------------------
def test_oracle_conditions_on_textbook_cases():
    T = {"sigma": 1, "tau": 1, "gamma": 1, "delta": 1}
    assert vv((0, 0), (1, 0), T) and not vv((0, 0), (2, 0), T)
    assert ev((0, 0), (10, 0), (5, 1), T) and not ev((0, 0), (10, 0), (11, 0), T)
    assert ee2((0, 0), (2, 2), (0, 2), (2, 0), T) and not ee2((0, 0), (2, 2), (3, 3), (4, 0), T)
    assert tv2((0, 0), (4, 0), (0, 4), (1, 1), T) and not tv2((0, 0), (4, 0), (0, 4), (2, 2), T)
    assert te((0, 0, 0), (4, 0, 0), (0, 4, 0), (1, 1, -1), (1, 1, 1), T)
    assert not te((0, 0, 0), (4, 0, 0), (0, 4, 0), (1, 1, 0), (1, 1, 1), T)
    assert tetv((0, 0, 0), (4, 0, 0), (0, 4, 0), (0, 0, 4), (1, 1, 1), T)
    assert ee3((0, 0, 0), (4, 0, 0), (2, -2, 1), (2, 2, 1), T)
    assert not ee3((0, 0, 0), (4, 0, 0), (2, -2, 2), (2, 2, 2), T)
    assert tv3((0, 0, 0), (4, 0, 0), (0, 4, 0), (1, 1, 1), T)
    assert not tv3((0, 0, 0), (4, 0, 0), (0, 4, 0), (1, 1, 2), T)


def test_oracle_catches_a_wrong_registration():
    ex = example("diagonal", 4)
    res = predicates.intersect(*ex["sim"], *ex["cut"])
    check_exact(res)
    p = res["vertex_vertex"]
    p.sim = p.sim[::-1].copy()  # pair every cut vertex with the wrong simulation vertex
    with pytest.raises(AssertionError):
        check_exact(res)
