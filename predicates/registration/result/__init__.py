"""What a registration returns: :class:`IntersectionResult` (a mapping of kind name to
:class:`KindPairs`), its exports (ParaView, plain data, data frames) and the consistency
counts used to compare it with the naive baseline."""
from predicates.registration.result.intersection import KIND_CODES, IntersectionResult, KindPairs

__all__ = ["KIND_CODES", "IntersectionResult", "KindPairs"]
