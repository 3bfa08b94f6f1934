"""The exact power-of-two scaling of the points (docs/resolution.md; step 2 of
:mod:`predicates.registration.pipeline`): ``points``·2^-e refused unless exact, so that
every value after it is the input's, scaled (moved from :mod:`.inputs`, which
re-exports these names)."""
from __future__ import annotations

import numpy as np

__all__ = ["scale_points", "times_pow2", "times_pow2_quiet"]


def scale_points(points: np.ndarray, e: int, role: str,
                 keep: np.ndarray | None = None, accelerate: bool = False) -> np.ndarray:
    """``points``·2^-e, refused unless exact (no overflow, no bit lost to underflow).
    ``keep`` (ascending row ids): every row is checked, block by block, but only the
    rows ``keep`` are returned scaled — the same refusals as for the whole array,
    without a scaled copy of every point (a partitioned run's plan keeps the run's
    vertices only: docs/partitioned.md 6). ``accelerate``: the scaling and both checks
    in one compiled pass (:func:`predicates.compiled.cellsums.scale_exact`: the same
    values and refusals, no temporaries)."""
    fi = np.finfo(points.dtype)
    if accelerate and keep is None and fi.minexp < -abs(e) and abs(e) < fi.maxexp:
        from predicates.compiled.cellsums import scale_exact

        out = np.empty_like(points)
        ty = points.dtype.type
        over, inexact = scale_exact(points, out, ty(2.0 ** -e), ty(2.0 ** e),
                                    float(fi.max / 16))
        if over or inexact:  # the numpy checks' refusal, in their order
            _check_scaled(points, out, e, role)
        return out
    if keep is not None:
        step, inexact = 1 << 16, None  # (each block's check is the whole array's on its rows)
        for a in range(0, len(points), step):
            block = points[a:a + step]
            out = times_pow2_quiet(block, -e)
            _check_scaled(block, out, e, role, exact=False)  # an overflow anywhere first
            if inexact is None:
                try:
                    _check_scaled(block, out, e, role, overflow=False)
                except ValueError as err:
                    inexact = err
        if inexact is not None:
            raise inexact
        return times_pow2(points[keep], -e)
    out = times_pow2_quiet(points, -e)
    _check_scaled(points, out, e, role)
    return out


def times_pow2_quiet(x: np.ndarray, k: int) -> np.ndarray:
    """:func:`times_pow2` with floating-point warnings off (the caller checks)."""
    with np.errstate(all="ignore"):
        return times_pow2(x, k)


def _check_scaled(points: np.ndarray, out: np.ndarray, e: int, role: str,
                  overflow: bool = True, exact: bool = True) -> None:
    """Refuse ``out`` = ``points``·2^-e if it overflowed or (``exact``) lost a bit."""
    limit = np.finfo(points.dtype).max / 16
    if overflow and not (np.isfinite(out).all() and np.all(np.abs(out) <= limit)):
        raise ValueError(f"the {role} coordinates are too large relative to the cells' size "
                         f"(scaling the cells to unit size by 2^{-e} overflows "
                         f"{points.dtype.name}): translate the meshes closer to the origin")
    if not exact:
        return
    step = 1 << 16  # scaled back block by block: no second array of the points
    with np.errstate(all="ignore"):
        exact = all(np.array_equal(times_pow2(out[a:a + step], e), points[a:a + step])
                    for a in range(0, len(points), step))
    if not exact:
        raise ValueError(f"the {role} coordinates cannot be scaled exactly by 2^{-e} (to "
                         f"unit-size cells): some are so small relative to the cells that "
                         f"they underflow {points.dtype.name}; round them to zero first")


def times_pow2(x: np.ndarray, k: int) -> np.ndarray:
    """``np.ldexp(x, k)`` (x·2^k correctly rounded, in x's dtype), as a multiplication
    by the power of two when 2^k is a normal number of that dtype — the same values
    (one correctly rounded operation either way), several times faster than ldexp."""
    fi = np.finfo(x.dtype)
    if fi.minexp < k < fi.maxexp:
        return x * x.dtype.type(2.0 ** k)
    return np.ldexp(x, k)
