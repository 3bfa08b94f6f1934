"""Shared hypothesis settings.

Two profiles: ``default`` (moderate, keeps ``pytest tests/`` fast) and ``long``
(thorough randomised runs), selected with the environment variable ``FPERR_LONG=1``.
Both have no deadline: exact and 300-bit evaluations vary a lot in cost.

Also puts tests/support (the shared exact-arithmetic helpers) on ``sys.path``: pytest's
default import mode adds each test file's own folder, not tests/, and test modules import
only from support, never from each other (tests/test_layout.py).
"""
import os
import pathlib
import sys

from hypothesis import HealthCheck, settings

SUPPORT = pathlib.Path(__file__).resolve().parent / "support"
if str(SUPPORT) not in sys.path:
    sys.path.insert(0, str(SUPPORT))

_COMMON = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])

settings.register_profile("default", max_examples=200, **_COMMON)
settings.register_profile("long", max_examples=5000, **_COMMON)
settings.load_profile("long" if os.environ.get("FPERR_LONG") == "1" else "default")
