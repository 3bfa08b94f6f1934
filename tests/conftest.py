"""Shared hypothesis settings.

Two profiles: ``default`` (moderate, keeps ``pytest tests/`` fast) and ``long``
(thorough randomised runs), selected with the environment variable ``FPERR_LONG=1``.
Both have no deadline: exact and 300-bit evaluations vary a lot in cost.
"""
import os

from hypothesis import HealthCheck, settings

_COMMON = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])

settings.register_profile("default", max_examples=200, **_COMMON)
settings.register_profile("long", max_examples=5000, **_COMMON)
settings.load_profile("long" if os.environ.get("FPERR_LONG") == "1" else "default")
