"""fperr: floating-point error bounds by the rules of Wang, Jiang, Schroeder and Teran,
*Robust Intersections under Floating Point*, section 2.

This layer knows nothing of geometry: it provides the instrumented number type
(:class:`Tracked`, rules A–K), exact bounds (:func:`bounds`), comparison records
(:class:`Check`) and the number-system contexts predicates are written against.
"""
from .bounds import Bounds, bounds, error, paper_integer
from .checks import Check
from .contexts import (Context, FloatContext, MpContext, NumpyContext, TrackedContext,
                       context_for)
from .symbols import EPS_MAX, L, eps
from .tracked import InvalidBound, Tracked, const, coord, exact_input, sqrt
from .shadow import Shadow, ShadowContext  # noqa: F401  (shadow execution: proofs.audit)
from .warnings import ResolutionError, ResolutionWarning

__all__ = [
    "Bounds", "Check", "Context", "EPS_MAX", "FloatContext", "InvalidBound", "L",
    "MpContext", "NumpyContext", "ResolutionError", "ResolutionWarning", "Tracked", "TrackedContext", "bounds", "const",
    "context_for", "coord", "eps", "error", "exact_input", "paper_integer", "sqrt",
]
__version__ = "0.1.0"
