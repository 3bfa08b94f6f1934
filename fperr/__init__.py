"""fperr: floating-point error bounds by the rules of Wang, Jiang, Schroeder and Teran,
*Robust Intersections under Floating Point*, section 2.

This layer knows nothing of geometry: it provides the instrumented number type
(:class:`Tracked`, rules A–K, operator table :mod:`fperr.ops`), exact bounds
(:func:`bounds`), comparison records (:class:`Check`), exact values and rounding
(:func:`to_fraction`, :func:`round_fraction`) and the number-system contexts predicates
are written against (:func:`context`).
"""
import sys
import types

from .contexts import Context, ExactContext, FloatContext, MpContext, NumpyContext
from .select import context, context_for
from .exact import ROUNDING, round_fraction, to_fraction, ulp
from .shadow import Shadow, ShadowContext  # noqa: F401  (shadow execution: proofs.audit)
from .warnings import ResolutionError, ResolutionWarning

#: The instrumented side (rules A–K are exact sympy arithmetic) loads on first use
#: (PEP 562), so the float and numpy paths never import sympy (docs/design.md).
_LAZY = {"Bounds": "bounds", "bounds": "bounds", "error": "bounds", "paper_integer": "bounds",
         "Check": "checks", "EPS_MAX": "symbols", "L": "symbols", "eps": "symbols",
         "InvalidBound": "tracked", "Tracked": "tracked", "const": "tracked",
         "coord": "tracked", "exact_input": "tracked", "sqrt": "tracked",
         "TrackedContext": "tracked_context"}


class _Package(types.ModuleType):
    """``fperr.bounds`` is the function: loading the submodule of that name lazily makes
    the import system set ``fperr.bounds = <module>``, which is ignored here (the module
    stays reachable as ``sys.modules["fperr.bounds"]``)."""

    def __setattr__(self, name, value):
        if not (name in _LAZY and isinstance(value, types.ModuleType)):
            super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'fperr' has no attribute {name!r}")
    import importlib
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "Bounds", "Check", "Context", "EPS_MAX", "ExactContext", "FloatContext", "InvalidBound",
    "L", "MpContext", "NumpyContext", "ROUNDING", "ResolutionError", "ResolutionWarning",
    "Tracked", "TrackedContext", "bounds", "const", "context", "context_for", "coord", "eps",
    "error", "exact_input", "paper_integer", "round_fraction", "sqrt", "to_fraction", "ulp",
]
__version__ = "0.1.0"
