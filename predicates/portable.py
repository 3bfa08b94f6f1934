"""Machine-independent arithmetic for example meshes and test inputs (docs/design.md,
"The same answer on every machine").

Matrix products (``@``, ``np.dot``), ``np.linalg`` and ``einsum(optimize=...)`` go through
BLAS/LAPACK kernels chosen for the CPU at run time (``OPENBLAS_CORETYPE``): their sums are
ordered and fused differently per kernel, so their last bits differ between machines.
Transcendental functions (``np.sin``, libm's ``cos``) are not correctly rounded and are
dispatched per CPU too. Anything that builds an example or a test input therefore uses the
functions here: IEEE basic operations (+ − × ÷ √, each correctly rounded) applied
elementwise in a fixed order, exact rational rotations, and sines and cosines correctly
rounded from exact arithmetic (mpmath at 128 bits).
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

__all__ = ["axis_rotation", "cos_sin", "dirichlet_ones", "dot", "exp2", "exp10", "log",
           "norm", "power", "rotate", "rotation", "row_norms", "unit_rows", "weighted_sum"]


def rotation(dim: int, seed: int = 1) -> np.ndarray:
    """A fixed proper rotation (det +1) of ℝ^dim, dim 2 or 3, as a (dim, dim) float64
    array whose entries are the correctly rounded values of an exact rational rotation.

    3D: the rotation of the quaternion q with non-zero integer components in [−9, 9]
    drawn from ``default_rng(seed).integers`` (integer draws are the same on every
    platform), R = (rational matrix of q)/|q|²; 2D: cos θ = (a² − b²)/(a² + b²),
    sin θ = 2ab/(a² + b²) for integers a, b ≥ 1 drawn the same way. Different seeds give
    different generic rotations (no axis-aligned entries)."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    rng = np.random.default_rng(seed)
    if dim == 2:
        a, b = (int(v) for v in rng.integers(1, 10, size=2))
        while a == b:  # a = b gives θ = 90°: axis-aligned
            b = int(rng.integers(1, 10))
        n = a * a + b * b
        c, s = Fraction(a * a - b * b, n), Fraction(2 * a * b, n)
        exact = [[c, -s], [s, c]]
    else:
        w, x, y, z = (int(v) * int(rng.choice([-1, 1])) for v in rng.integers(1, 10, size=4))
        n = w * w + x * x + y * y + z * z
        exact = [[w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
                 [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
                 [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]]
        exact = [[Fraction(v, n) for v in row] for row in exact]
    return np.array([[float(v) for v in row] for row in exact], dtype=np.float64)


def axis_rotation(axis, angle: float) -> np.ndarray:
    """The 3D rotation by ``angle`` radians about ``axis`` (Rodrigues: I + sin·K +
    (1 − cos)·K², K the cross-product matrix of the unit axis) with IEEE operations and
    :func:`cos_sin`: the same bits on every machine. For the tiny rotations of tests and
    examples (a few ulp: configurations just off the grid)."""
    k = np.asarray(axis, dtype=np.float64)
    k = k / norm(k)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    (c,), (s,) = cos_sin(np.array([float(angle)]))
    return np.eye(3) + s * K + (1 - c) * rotate(K, K.T)


def rotate(points: np.ndarray, R: np.ndarray) -> np.ndarray:
    """points (N, d) → (N, d), row i ↦ R·row i, each coordinate summed left to right
    ((x₀R₀ + x₁R₁) + x₂R₂) with IEEE operations: the same bits on every machine (unlike
    ``points @ R.T``)."""
    P = np.asarray(points, dtype=np.float64)
    R = np.asarray(R, dtype=np.float64)
    out = np.empty((len(P), R.shape[0]), dtype=np.float64)
    for i in range(R.shape[0]):
        acc = P[:, 0] * R[i, 0]
        for j in range(1, R.shape[1]):
            acc = acc + P[:, j] * R[i, j]
        out[:, i] = acc
    return out


def weighted_sum(w: np.ndarray, X: np.ndarray) -> np.ndarray:
    """w (m, k), X (m, k, d) → (m, d): Σⱼ wⱼ·Xⱼ summed left to right in float64 (the
    order ``einsum("mk,mkd->md")`` promises nothing about)."""
    w = np.asarray(w, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    acc = w[:, 0, None] * X[:, 0]
    for j in range(1, w.shape[1]):
        acc = acc + w[:, j, None] * X[:, j]
    return acc


def row_norms(v: np.ndarray) -> np.ndarray:
    """(N, d) → (N,): √(Σ vⱼ²) summed left to right (the order ``np.linalg.norm(v,
    axis=1)`` uses on rows of 2 or 3, without its dispatch)."""
    v = np.asarray(v, dtype=np.float64)
    acc = v[:, 0] * v[:, 0]
    for j in range(1, v.shape[1]):
        acc = acc + v[:, j] * v[:, j]
    return np.sqrt(acc)


def unit_rows(v: np.ndarray) -> np.ndarray:
    """Each row of ``v`` divided by its :func:`row_norms`."""
    v = np.asarray(v, dtype=np.float64)
    return v / row_norms(v)[:, None]


def power(x: np.ndarray, p: float) -> np.ndarray:
    """x^p elementwise for p a non-negative multiple of ½, by products and one √ (each
    correctly rounded; a general ``x ** p`` calls a pow that differs by CPU)."""
    twice = 2 * float(p)
    if twice != int(twice) or p < 0:
        raise ValueError(f"p must be a non-negative multiple of 1/2, got {p!r}")
    x = np.asarray(x, dtype=np.float64)
    out = np.ones_like(x)
    for _ in range(int(twice) // 2):
        out = out * x
    return out * np.sqrt(x) if int(twice) % 2 else out


def cos_sin(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cos t, sin t) of each float64 in ``t``, correctly rounded: evaluated in mpmath at
    128 bits and rounded to nearest once. (A libm or SIMD ``cos`` may be off by an ulp,
    differently on different CPUs.)"""
    import mpmath
    from mpmath.libmp import to_float

    t = np.asarray(t, dtype=np.float64)
    c = np.empty(t.shape)
    s = np.empty(t.shape)
    with mpmath.workprec(128):
        for i, x in enumerate(t.ravel().tolist()):
            m = mpmath.mpf(x)
            c.flat[i] = to_float(mpmath.cos(m)._mpf_, rnd="n")
            s.flat[i] = to_float(mpmath.sin(m)._mpf_, rnd="n")
    return c, s


def dot(a, b) -> float:
    """Σ aⱼbⱼ of two vectors, summed left to right (``a @ b`` calls BLAS)."""
    a = np.asarray(a, dtype=np.float64).ravel()
    b = np.asarray(b, dtype=np.float64).ravel()
    acc = a[0] * b[0]
    for j in range(1, len(a)):
        acc = acc + a[j] * b[j]
    return float(acc)


def norm(v) -> float:
    """√(v·v) with :func:`dot` (``np.linalg.norm`` calls BLAS)."""
    return float(np.sqrt(dot(v, v)))


def _rounded(f, x: float) -> float:
    import mpmath
    from mpmath.libmp import to_float

    with mpmath.workprec(128):
        return to_float(f(mpmath.mpf(float(x)))._mpf_, rnd="n")


def exp2(x: float) -> float:
    """2^x correctly rounded (``2.0 ** x`` calls libm's pow)."""
    import mpmath

    return _rounded(lambda m: mpmath.power(2, m), x)


def exp10(x: float) -> float:
    """10^x correctly rounded (``10 ** x`` calls libm's pow)."""
    import mpmath

    return _rounded(lambda m: mpmath.power(10, m), x)


def log(x: float) -> float:
    """The natural logarithm, correctly rounded (``math.log`` is libm's)."""
    import mpmath

    if not x > 0:
        raise ValueError(f"log of a non-positive number {x!r}")
    return _rounded(mpmath.log, x)


def dirichlet_ones(rng: np.random.Generator, size: int, n: int) -> np.ndarray:
    """(size, n) weights uniform on the simplex (Dirichlet(1, …, 1)): the spacings of
    n − 1 sorted uniform draws in [0, 1] (``rng.dirichlet`` draws gammas through libm's
    exp/log)."""
    u = np.sort(rng.random((size, n - 1)), axis=1)
    edges = np.concatenate([np.zeros((size, 1)), u, np.ones((size, 1))], axis=1)
    return np.diff(edges, axis=1)
