"""predicates.portable: results with IEEE operations only, the same bits on every machine
(docs/design.md, "The same answer on every machine"), checked against Python floats
(the same operations in the same order) and mpmath at high precision."""
from __future__ import annotations

import mpmath
import numpy as np
import pytest

from predicates.portable import axis_rotation, rotate


def test_rotate_is_the_left_to_right_sum_of_python_floats():
    rng = np.random.default_rng(5)
    P, R = rng.standard_normal((50, 3)), rng.standard_normal((3, 3))
    got = rotate(P, R)
    for i, p in enumerate(P.tolist()):
        for r in range(3):
            acc = p[0] * float(R[r, 0])
            acc = acc + p[1] * float(R[r, 1])
            acc = acc + p[2] * float(R[r, 2])
            assert got[i, r] == acc


@pytest.mark.parametrize("axis, angle", [((1.0, 2.0, 0.0), 2 * 2.0**-52),
                                         ((1.0, 2.0, 0.0), 8 * 2.0**-52),
                                         ((0.3, -1.0, 2.5), 0.7), ((0.0, 0.0, 1.0), 3.0)])
def test_axis_rotation_is_rodrigues_to_a_few_ulp(axis, angle):
    mpmath.mp.prec = 200
    k = [mpmath.mpf(a) for a in axis]
    n = mpmath.sqrt(sum(a * a for a in k))
    k = [a / n for a in k]
    c, s = mpmath.cos(angle), mpmath.sin(angle)
    K = [[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]]
    R = axis_rotation(axis, angle)
    for i in range(3):
        for j in range(3):
            K2 = sum(K[i][m] * K[m][j] for m in range(3))
            exact = (1 if i == j else 0) + s * K[i][j] + (1 - c) * K2
            assert abs(R[i, j] - exact) <= 4 * 2.0**-52, (i, j)
    # the axis is fixed and the angle is the one asked (to rounding)
    fixed = rotate(np.array([axis]), R)[0]
    assert np.all(np.abs(fixed - np.array(axis)) <= 8 * 2.0**-52 * max(map(abs, axis)))
