"""The tolerance table the proofs run on: Figure 1 / Figure 5, optionally overridden.

Values come from :mod:`predicates.tolerance_table` (exact data), here in sympy. A tolerance T
with spec (lo, mid, hi, q, p) stands for T− = lo·ε^q·L^p, T = mid·ε^q·L^p,
T+ = hi·ε^q·L^p.

Override files (``fperr verify --tolerances FILE``) replace coefficients. JSON::

    {"3": {"phi": {"lo": 200}}, "2": {"kappa": {"mid": 9.5}}}

or TOML (same structure)::

    [3.phi]
    lo = 200

    [2.kappa]
    mid = 9.5

Top-level keys are the dimension ("2"/"3", also "2d"/"3d"); then the tolerance name as in
the tables (2D: sigma, tau, sigma_hat, kappa; 3D: sigma, tau, delta, gamma, sigma_hat,
lam, phi, nu, zeta, mu, xi, rho); then any of ``lo`` (T−), ``mid`` (T), ``hi`` (T+)
(aliases ``T-``/``minus``, ``T``, ``T+``/``plus``). A value is the coefficient of
ε^q·L^p: an integer, a decimal (read exactly: 9.5 = 19/2, 0.1 = 1/10) or a string
holding an exact expression ("12*sqrt(3)*1521/16") in the bounded grammar of
:mod:`predicates.coefficients` (read as data, never evaluated as Python). ``mid`` must be rational (the code
computes T from it); it is also re-run through the instrumented tolerance computation,
so its derived R[T] is that of the new constant.
"""
from __future__ import annotations

import json
import tomllib
from dataclasses import replace
from fractions import Fraction
from pathlib import Path

import sympy

from fperr.symbols import L, eps
from predicates import coefficients
from predicates.tolerance_table import TABLES as EXACT_TABLES
from predicates.tolerance_table import ToleranceSpec, from_sympy

FIELDS = {"lo": "lo", "t-": "lo", "minus": "lo", "mid": "mid", "t": "mid",
          "hi": "hi", "t+": "hi", "plus": "hi"}
#: the largest override file read (a table is a few hundred bytes)
MAX_FILE_BYTES = 1 << 20


class ToleranceFileError(ValueError):
    """An override file that cannot be used (unknown name, bad value, ...)."""


def as_sympy(x) -> sympy.Expr:
    """An exact coefficient (Fraction, int, :class:`predicates.coefficients.Monomial`
    or already sympy) as sympy, built from its value (never from text)."""
    if isinstance(x, sympy.Basic):
        return x
    if isinstance(x, (int, Fraction)):
        return sympy.Rational(Fraction(x).numerator, Fraction(x).denominator)
    return coefficients.to_sympy(x)


def sympy_spec(spec: ToleranceSpec) -> ToleranceSpec:
    """The same spec with sympy coefficients and exponent (what the proofs compute with)."""
    return replace(spec, lo=as_sympy(spec.lo), mid=as_sympy(spec.mid), hi=as_sympy(spec.hi),
                   q=as_sympy(spec.q))


#: Figures 1 and 5 in sympy (:data:`predicates.tolerance_table.TABLES` holds them exactly
#: without sympy, for the float and numpy paths).
TABLES = {dim: {n: sympy_spec(s) for n, s in tab.items()} for dim, tab in EXACT_TABLES.items()}


def _coefficient(v, where: str) -> sympy.Expr:
    """A positive constant read by :mod:`predicates.coefficients` (strings are data in
    its bounded grammar, never sympified), as sympy."""
    try:
        return as_sympy(coefficients.constant(from_sympy(v)))
    except coefficients.CoefficientError as e:
        raise ToleranceFileError(f"{where}: {e}") from None


def parse_overrides(data: dict, known: dict | None = None
                    ) -> dict[int, dict[str, dict[str, sympy.Expr]]]:
    """Validate the structure of an override mapping (see module docstring); ``known``:
    the tables whose names it may override ({dim: {name: ...}}, default Figures 1/5)."""
    known = TABLES if known is None else known
    if not isinstance(data, dict):
        raise ToleranceFileError("top level must be a table/object keyed by dimension")
    out: dict[int, dict[str, dict[str, sympy.Expr]]] = {}
    for dkey, entries in data.items():
        d = str(dkey).lower().removesuffix("d")
        if d not in ("2", "3") or int(d) not in known:
            raise ToleranceFileError(f"unknown dimension {dkey!r} (use "
                                     + " or ".join(f'"{k}"' for k in sorted(known)) + ")")
        dim = int(d)
        if not isinstance(entries, dict):
            raise ToleranceFileError(f"[{dkey}] must map tolerance names to fields")
        for name, fields in entries.items():
            if name not in known[dim]:
                raise ToleranceFileError(
                    f"unknown {dim}D tolerance {name!r}; known: {', '.join(known[dim])}")
            if not isinstance(fields, dict):
                raise ToleranceFileError(f"[{dkey}.{name}] must map lo/mid/hi to values")
            for fkey, v in fields.items():
                f = FIELDS.get(str(fkey).lower())
                if f is None:
                    raise ToleranceFileError(
                        f"[{dkey}.{name}]: unknown field {fkey!r} (use lo, mid, hi)")
                x = _coefficient(v, f"{dim}D {name}.{f}")
                if f == "mid" and not x.is_Rational:
                    raise ToleranceFileError(f"{dim}D {name}.mid must be rational "
                                             f"(the code computes T from it), got {v!r}")
                out.setdefault(dim, {}).setdefault(name, {})[f] = x
    return out


def load_overrides(path: str | Path, known: dict | None = None
                   ) -> dict[int, dict[str, dict[str, sympy.Expr]]]:
    """Read a TOML (``.toml``) or JSON file of coefficient overrides (``known``: as for
    :func:`parse_overrides`)."""
    p = Path(path)
    try:
        if p.stat().st_size > MAX_FILE_BYTES:
            raise ToleranceFileError(f"{path}: larger than {MAX_FILE_BYTES} bytes: not a "
                                     "tolerance table")
        raw = p.read_bytes()
    except OSError as e:
        raise ToleranceFileError(f"cannot read {path}: {e}") from None
    try:
        if p.suffix.lower() == ".toml":
            data = tomllib.loads(raw.decode())
        elif p.suffix.lower() == ".json":
            data = json.loads(raw)
        else:  # sniff
            try:
                data = json.loads(raw)
            except ValueError:
                data = tomllib.loads(raw.decode())
    except (ValueError, RecursionError) as e:  # (TOMLDecodeError is a ValueError)
        raise ToleranceFileError(f"{path}: not valid TOML/JSON: {e}") from None
    try:
        return parse_overrides(data, known)
    except ToleranceFileError as e:  # the message names the key; add the file
        raise ToleranceFileError(f"{path}: {e}") from None


def table(dim: int, overrides: dict | None = None) -> dict[str, ToleranceSpec]:
    """Figure 1 (dim 2) / Figure 5 (dim 3), with ``overrides[dim]`` applied (validated
    and made exact by :func:`parse_overrides`)."""
    base = dict(TABLES[dim])
    overrides = parse_overrides(overrides) if overrides else {}
    for name, fields in (overrides.get(dim) or {}).items():
        base[name] = replace(base[name], **fields)
    return base


def is_default(tab: dict, dim: int) -> bool:
    return all(tab[k] == TABLES[dim][k] for k in TABLES[dim])


class Values:
    """T−, T, T+ of a table as exact expressions in ε and L."""

    def __init__(self, tab: dict[str, ToleranceSpec]):
        self.tab = tab

    def _v(self, name, coeff):
        spec = self.tab[name]
        return coeff * eps**spec.q * L**spec.p

    def lo(self, name):
        return self._v(name, self.tab[name].lo)

    def mid(self, name):
        return self._v(name, self.tab[name].mid)

    def hi(self, name):
        return self._v(name, self.tab[name].hi)

    def all(self, name):
        return self.lo(name), self.mid(name), self.hi(name)

    def __contains__(self, name):
        return name in self.tab
