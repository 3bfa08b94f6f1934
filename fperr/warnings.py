"""Warning and error categories of the library's resolution checks (paper, section 4.1:
the tolerances grow with the scale L of the primitives processed).

``ResolutionWarning``: the run completed, but its tolerances are a sizeable fraction of
the elements near the interface, so the result does not resolve the geometry.
``ResolutionError``: the same refused up front (``strict=True``), or a run whose
candidate pairs would exhaust memory. A ``ValueError``: the input is valid but cannot be
resolved at this precision.
"""
from __future__ import annotations

__all__ = ["ResolutionError", "ResolutionWarning"]


class ResolutionWarning(UserWarning):
    """The tolerances are coarse relative to the elements near the interface."""


class ResolutionError(ValueError):
    """The run was refused: the tolerances cannot resolve the elements near the
    interface (``strict=True``) or the candidate pairs would exhaust memory."""
