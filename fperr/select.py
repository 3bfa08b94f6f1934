"""Choosing a number system: :func:`context` by name and :func:`context_for` by the
inputs' number type. Above both kinds of context: the native ones
(:mod:`fperr.contexts`) and the instrumented one (:mod:`fperr.tracked_context`, loaded
only when asked for, since it loads sympy)."""
from __future__ import annotations

import sys
from fractions import Fraction

import mpmath
import numpy as np

from .contexts import Context, ExactContext, FloatContext, MpContext, NumpyContext

__all__ = ["context", "context_for"]

_NAMES = "binary64, binary32, numpy.float64, numpy.float32, mp<bits>, exact, tracked"


def context(spec=None) -> Context:
    """The number system named by ``spec``: a fresh context.

    ``"binary64"`` / ``float`` / None → :class:`FloatContext`; ``"binary32"`` →
    ``NumpyContext(float32)`` (numpy is Python's only binary32); a numpy dtype or its
    name (``np.float64``, ``"float32"``, ``"numpy.float64"``) → :class:`NumpyContext`;
    ``"mp17"`` or an int precision → :class:`MpContext`; ``"exact"`` / ``Fraction`` →
    :class:`ExactContext`; ``"tracked"`` → the instrumented context; a context → itself.
    """
    if isinstance(spec, Context):
        return spec
    if spec is None or spec is float:
        return FloatContext()
    if spec is Fraction:
        return ExactContext()
    if isinstance(spec, bool):
        raise TypeError(f"unknown number system {spec!r} (choose from {_NAMES})")
    if isinstance(spec, int):
        return MpContext(spec)
    key = spec
    if isinstance(spec, str):
        key = spec.strip().lower()
        named = {"binary64": FloatContext, "binary32": lambda: NumpyContext(np.float32),
                 "exact": ExactContext, "tracked": _tracked}
        if key in named:
            return named[key]()
        if key.startswith("mp") and key[2:].isdigit():
            return MpContext(int(key[2:]))
        key = key.removeprefix("numpy.")
    try:
        dt = np.dtype(key)
    except TypeError:
        raise ValueError(f"unknown number system {spec!r} (choose from {_NAMES})") from None
    return NumpyContext(dt)


def _tracked() -> Context:  # imported on use: it loads sympy, floats never do
    from .tracked_context import TrackedContext
    return TrackedContext()


def context_for(*values) -> Context:
    """The context matching the inputs' number type (Tracked, numpy, mpmath, float)."""
    tracked = sys.modules.get("fperr.tracked")  # not loaded: no Tracked value exists
    flat = [v for p in values for v in (p if isinstance(p, (tuple, list)) else (p,))]
    if tracked is not None and any(isinstance(v, tracked.Tracked) for v in flat):
        return _tracked()
    if any(isinstance(v, np.ndarray) for v in values):
        return NumpyContext(np.result_type(*[np.asarray(v).dtype for v in values]))
    return MpContext(mpmath.mp.prec) if any(isinstance(v, mpmath.mpf) for v in flat) \
        else FloatContext()
