"""The analysis scales (docs/proofs.md, "Quotients and roots" for the rules; fperr/state.py,
fperr/tracked.py for the representation): a sum of 2,000 products completes — no text
is built, no recursion — and its bound equals the closed form of rules F and B."""
from __future__ import annotations

from fractions import Fraction

import sympy

import fperr
from fperr.symbols import L, eps


def closed_form(n: int) -> tuple[Fraction, Fraction]:
    """(A, B) with E = (A·ε + B·ε²)·L² for x1·y1 + ... + xn·yn summed left to right.

    Rule K: c = 1/2; rule F: each product c = 1/4, a = b = 1. Rule B with
    A_k = c_k·a_k, B_k = c_k·b_k, c_k = k/4: A_k = A_{k−1} + (k + 1)/4 and
    B_k = B_{k−1} + A_{k−1} + 3/2 from A_1 = B_1 = 1/4, so
    A_n = (n + 1)(n + 2)/8 − 1/2 and
    B_n = 1/4 + 3(n − 1)/2 + Σ_{j<n} A_j, Σ_{j≤m} A_j = ((m+1)(m+2)(m+3)/3 − 2)/8 − m/2."""
    A = Fraction((n + 1) * (n + 2), 8) - Fraction(1, 2)
    m = n - 1
    sum_A = (Fraction((m + 1) * (m + 2) * (m + 3), 3) - 2) / 8 - Fraction(m, 2)
    B = Fraction(1, 4) + Fraction(3 * (n - 1), 2) + sum_A
    return A, B


def _sum_of_products(n: int) -> fperr.Tracked:
    s = fperr.coord("x0") * fperr.coord("y0")
    for i in range(1, n):
        s = s + fperr.coord(f"x{i}") * fperr.coord(f"y{i}")
    return s


def test_closed_form_matches_small_sums_step_by_step():
    for n in (1, 2, 3, 7):
        A, B = closed_form(n)
        st = _sum_of_products(n).state
        assert st.c * st.a == sympy.Rational(A.numerator, A.denominator)
        assert st.c * st.b == sympy.Rational(B.numerator, B.denominator)


def test_sum_of_2000_products_completes_with_its_closed_form_bound():
    s = _sum_of_products(2000)
    A, B = closed_form(2000)
    expected = (sympy.Rational(A.numerator, A.denominator) * eps
                + sympy.Rational(B.numerator, B.denominator) * eps**2) * L**2
    assert sympy.expand(fperr.bounds(s).E - expected) == 0
    assert s.state.c == 500 and s.rule == "B"
    # the text exists on demand, built without recursion: 2,000 products, 1,999 sums
    assert s.s.count("*") == 2000 and s.s.count("+") == 1999
    assert len(list(s.walk())) == 3 * 2000 + 1999
