"""fperr: floating-point error bounds by the rules of Wang, Jiang, Schroeder and Teran,
*Robust Intersections under Floating Point*, section 2.

This layer knows nothing of geometry: it provides the instrumented number type
(:class:`Tracked`, rules A–K, operator table :mod:`fperr.ops`), exact bounds
(:func:`bounds`), comparison records (:class:`Check`), exact values and rounding
(:func:`to_fraction`, :func:`round_fraction`) and the number-system contexts predicates
are written against (:func:`context`).
"""
from .bounds import Bounds, bounds, error, paper_integer
from .checks import Check
from .contexts import (Context, ExactContext, FloatContext, MpContext, NumpyContext, context,
                       context_for)
from .exact import ROUNDING, round_fraction, to_fraction, ulp
from .symbols import EPS_MAX, L, eps
from .tracked import InvalidBound, Tracked, const, coord, exact_input, sqrt
from .tracked_context import TrackedContext
from .shadow import Shadow, ShadowContext  # noqa: F401  (shadow execution: proofs.audit)
from .warnings import ResolutionError, ResolutionWarning

__all__ = [
    "Bounds", "Check", "Context", "EPS_MAX", "ExactContext", "FloatContext", "InvalidBound",
    "L", "MpContext", "NumpyContext", "ROUNDING", "ResolutionError", "ResolutionWarning",
    "Tracked", "TrackedContext", "bounds", "const", "context", "context_for", "coord", "eps",
    "error", "exact_input", "paper_integer", "round_fraction", "sqrt", "to_fraction", "ulp",
]
__version__ = "0.1.0"
