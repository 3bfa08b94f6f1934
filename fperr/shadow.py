"""Shadow execution: a number that carries its working-precision value *and* its exact value.

A :class:`Shadow` holds

* ``w`` — the value the real floating-point path computes: a Python float (binary64), a
  numpy float32/float64 scalar or array, or an mpmath ``mpf`` rounded at a given
  precision (see :class:`WorkingFormat`);
* ``x`` — the exact value of the same expression on the same (exact) inputs;
* ``lo`` / ``hi`` — for quantities computed from a *bracketed* input (a tolerance T with
  its exact brackets T− and T+, section 3 of the paper): the exact value with T− resp.
  T+ substituted for T. ``None`` for quantities that do not depend on a tolerance.

Operators act on all parts at once. A :class:`ShadowContext` runs a predicate written
against :class:`fperr.Context` with shadow numbers: it follows the **working** value's
decisions (so the real floating-point path runs, early returns included) and records every
named quantity and every comparison, whose exact decisions at T, T− and T+ can then be
read from the record (:meth:`ShadowCheck.exact_decision`).

The exact reference
-------------------
Exact values are :class:`fractions.Fraction` whenever the value is rational: every input
coordinate, constant and working value is a dyadic rational, so sums, differences,
products and quotients stay exact. A square root that is not rational (edge-vertex's
m = ‖û‖, the ε^(1/2) and ε^(1/4) factors of the tolerances, the √3 in some T+) becomes a
*rigorous* interval (mpmath's interval arithmetic at :data:`REFERENCE_PREC` = 300 bits,
outward rounded), and everything computed from it stays an interval. So the reference is
either exact or an enclosure whose width is about 2^-290 relative to the magnitudes
involved — negligible against the ε² terms of every bound (ε² ≥ 2^-106). Measured errors
use the interval's far end (an upper bound of the true error), and comparisons decide only
when the enclosure does: :func:`compare` returns ``None`` (undecided) otherwise.

This module knows nothing of geometry; :mod:`proofs.audit` uses it to audit the
predicates.
"""
from __future__ import annotations

import math
from contextlib import contextmanager
from fractions import Fraction

import mpmath
import numpy as np
from mpmath import libmp

from .contexts import Context, mp_to_fraction

__all__ = ["BINARY32", "BINARY64", "NP_BINARY64", "REFERENCE_PREC", "RInterval", "Shadow",
           "ShadowCheck", "ShadowContext", "WorkingFormat", "compare", "exact_sqrt",
           "interval_from_float", "lower_fraction", "mp_format", "round_to_bits",
           "to_fraction", "upper_fraction"]

#: Significand bits of the endpoints of the reference intervals (irrational exact values).
REFERENCE_PREC = 300


# --------------------------------------------------------------------------------------
# exact values: Fraction, or a rigorous rational interval; None = undefined (0/0 in a lane
# the working path had already rejected)
# --------------------------------------------------------------------------------------
def _floor_log2(n: int, d: int) -> int:
    e = n.bit_length() - d.bit_length()
    if (n << max(-e, 0)) < (d << max(e, 0)):
        e -= 1
    return e


def _round_dir(q: Fraction, up: bool, bits: int = REFERENCE_PREC) -> Fraction:
    """q rounded to ``bits`` significant bits toward +inf (up) or -inf (down)."""
    n, d = q.numerator, q.denominator
    if n == 0 or (d & (d - 1) == 0 and abs(n).bit_length() <= bits):
        return q
    neg = n < 0
    n = -n if neg else n
    shift = _floor_log2(n, d) - bits + 1
    if shift >= 0:
        k, r = divmod(n, d << shift)
    else:
        k, r = divmod(n << -shift, d)
    if r and (up != neg):  # magnitude rounded up
        k += 1
    v = Fraction(k << shift) if shift >= 0 else Fraction(k, 1 << -shift)
    return -v if neg else v


class RInterval:
    """A closed interval [lo, hi] with dyadic rational endpoints of at most
    :data:`REFERENCE_PREC` significant bits, rounded outward after every operation: a
    rigorous enclosure of an irrational exact value."""

    __slots__ = ("lo", "hi")

    def __init__(self, lo: Fraction, hi: Fraction):
        self.lo = _round_dir(lo, False)
        self.hi = _round_dir(hi, True)

    @staticmethod
    def of(q):
        return q if type(q) is RInterval else RInterval(q, q)

    def __add__(self, o):
        o = RInterval.of(o)
        return RInterval(self.lo + o.lo, self.hi + o.hi)

    __radd__ = __add__

    def __sub__(self, o):
        o = RInterval.of(o)
        return RInterval(self.lo - o.hi, self.hi - o.lo)

    def __rsub__(self, o):
        return RInterval.of(o) - self

    def __mul__(self, o):
        o = RInterval.of(o)
        p = (self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi)
        return RInterval(min(p), max(p))

    __rmul__ = __mul__

    def __truediv__(self, o):
        o = RInterval.of(o)
        if o.lo <= 0 <= o.hi:
            raise ZeroDivisionError("interval divisor contains zero")
        return self * RInterval(_round_dir(1 / o.hi, False), _round_dir(1 / o.lo, True))

    def __rtruediv__(self, o):
        return RInterval.of(o) / self

    def __neg__(self):
        return RInterval(-self.hi, -self.lo)

    def __abs__(self):
        if self.lo >= 0:
            return self
        if self.hi <= 0:
            return -self
        return RInterval(Fraction(0), max(-self.lo, self.hi))

    def sqrt(self):
        lo = self.lo if self.lo > 0 else Fraction(0)  # an enclosure of x >= 0 may dip below 0
        if self.hi < 0:
            raise ValueError("square root of a negative exact value")
        return RInterval(_sqrt_bound(lo, False), _sqrt_bound(self.hi, True))

    def mid(self) -> Fraction:
        return (self.lo + self.hi) / 2

    def __float__(self):
        return float(self.mid())

    def __repr__(self):
        return f"RInterval({float(self.lo)!r}, width 2^{_log2w(self)})"


def _log2w(iv):
    w = iv.hi - iv.lo
    return "-inf" if w == 0 else _floor_log2(w.numerator, w.denominator)


def _sqrt_bound(q: Fraction, up: bool) -> Fraction:
    """A dyadic bound of √q (q ≥ 0) with about REFERENCE_PREC + 8 significant bits."""
    n, d = q.numerator, q.denominator
    if n == 0:
        return Fraction(0)
    # √(n/d) = √(n·d)/d; scale by 4^k so the integer root has enough bits
    nd = n * d
    k = max(0, (REFERENCE_PREC + 8) - nd.bit_length() // 2)
    r = math.isqrt(nd << (2 * k))
    if up and r * r != (nd << (2 * k)):
        r += 1
    return Fraction(r, d << k)


def _add(a, b):
    if a is None or b is None:
        return None
    return a + b if type(a) is Fraction else RInterval.of(a) + b


def _sub(a, b):
    if a is None or b is None:
        return None
    return a - b if type(a) is Fraction else RInterval.of(a) - b


def _mul(a, b):
    if a is None or b is None:
        return None
    return a * b if type(a) is Fraction else RInterval.of(a) * b


def _div(a, b):
    if a is None or b is None:
        return None
    try:
        return a / b if type(a) is Fraction else RInterval.of(a) / b
    except ZeroDivisionError:
        return None


def _neg(a):
    return None if a is None else -a


def _abs(a):
    return None if a is None else abs(a)


def exact_sqrt(q):
    """√q: a Fraction when q is the square of a rational, else a rigorous interval."""
    if q is None:
        return None
    if type(q) is Fraction:
        if q < 0:
            raise ValueError(f"square root of a negative exact value {q}")
        n, d = q.numerator, q.denominator
        rn, rd = math.isqrt(n), math.isqrt(d)
        if rn * rn == n and rd * rd == d:
            return Fraction(rn, rd)
        return RInterval(_sqrt_bound(q, False), _sqrt_bound(q, True))
    return q.sqrt()


def compare(a, b):
    """Exact comparison: -1, 0 or 1, or ``None`` when an interval cannot decide."""
    if type(a) is Fraction and type(b) is Fraction:
        return (a > b) - (a < b)
    if a is None or b is None:
        return None
    d = RInterval.of(a) - b
    if d.lo > 0:
        return 1
    if d.hi < 0:
        return -1
    if d.lo == 0 and d.hi == 0:
        return 0
    return None


def upper_fraction(a) -> Fraction | None:
    """|a| as a Fraction, or an upper bound of it for an interval (its far end)."""
    if a is None:
        return None
    if type(a) is Fraction:
        return abs(a)
    return abs(a).hi


def lower_fraction(a) -> Fraction | None:
    """|a| as a Fraction, or a lower bound of it for an interval (its near end)."""
    if a is None:
        return None
    if type(a) is Fraction:
        return abs(a)
    return abs(a).lo


def interval_from_float(v, rel=Fraction(1, 2**280)) -> RInterval:
    """A rigorous interval around a high-precision decimal approximation ``v`` of a real
    number (e.g. ``sympy.N(expr, 130)``) known to be accurate to better than ``rel``."""
    q = Fraction(str(v)) if not isinstance(v, Fraction) else v
    delta = abs(q) * rel
    return RInterval(q - delta, q + delta)


# vectorised versions for object arrays (array working values)
_vadd = np.frompyfunc(_add, 2, 1)
_vsub = np.frompyfunc(_sub, 2, 1)
_vmul = np.frompyfunc(_mul, 2, 1)
_vdiv = np.frompyfunc(_div, 2, 1)
_vneg = np.frompyfunc(_neg, 1, 1)
_vabs = np.frompyfunc(_abs, 1, 1)
_vsqrt = np.frompyfunc(exact_sqrt, 1, 1)
_vcmp = np.frompyfunc(compare, 2, 1)


def _arr(*xs):
    return any(isinstance(x, np.ndarray) for x in xs)


# --------------------------------------------------------------------------------------
# working formats
# --------------------------------------------------------------------------------------
def round_to_bits(q: Fraction, bits: int, mode: str = "n") -> Fraction:
    """``q`` rounded to a ``bits``-bit significand (no exponent limits): mode ``"n"``
    nearest-even, ``"z"`` toward zero."""
    q = Fraction(q)
    n, d = q.numerator, q.denominator
    if n == 0:
        return q
    s = -1 if n < 0 else 1
    n = abs(n)
    # e = floor(log2(n/d))
    e = n.bit_length() - d.bit_length()
    if (n << max(-e, 0)) < (d << max(e, 0)):
        e -= 1
    shift = e - bits + 1  # unit = 2^shift
    if shift >= 0:
        k, r2, den = divmod(n, d << shift) + (d << shift,)
    else:
        k, r2, den = divmod(n << -shift, d) + (d,)
    if mode == "n" and (2 * r2 > den or (2 * r2 == den and k & 1)):
        k += 1
    return s * (Fraction(k << shift) if shift >= 0 else Fraction(k, 1 << -shift))


class WorkingFormat:
    """A working number format: how to make, convert and round its values.

    ``kind``: ``"float"`` (Python float, binary64), ``"numpy"`` (numpy scalar or array
    of ``dtype``), ``"mp"`` (mpmath ``mpf`` at ``prec`` bits). ``eps`` is the unit
    roundoff 2^-prec (a Fraction), ``bits`` the significand, ``min_normal`` the smallest
    normal magnitude (None: unbounded exponent).
    """

    def __init__(self, name: str, kind: str, bits: int, dtype=None, min_normal=None):
        self.name = name
        self.kind = kind
        self.bits = int(bits)
        self.dtype = None if dtype is None else np.dtype(dtype)
        self.eps = Fraction(1, 2 ** self.bits)
        self.min_normal = min_normal
        if kind == "mp":
            self.sqrt = mpmath.sqrt
        elif kind == "numpy":
            self.sqrt = np.sqrt
        else:
            self.sqrt = math.sqrt

    def __repr__(self):
        return f"<WorkingFormat {self.name}: {self.bits}-bit significand, ε = 2^-{self.bits}>"

    @contextmanager
    def session(self):
        """The arithmetic environment: mpmath precision, numpy error state."""
        if self.kind == "mp":
            with mpmath.workprec(self.bits):
                yield
        elif self.kind == "numpy":
            with np.errstate(all="ignore"):
                yield
        else:
            yield

    # conversions ------------------------------------------------------------------
    def from_fraction(self, q: Fraction):
        """The working value nearest to ``q`` (round to nearest even)."""
        q = Fraction(q)
        if self.kind == "mp":
            t = libmp.from_rational(q.numerator, q.denominator, self.bits, libmp.round_nearest)
            return mpmath.mp.make_mpf(t)
        r = float(round_to_bits(q, self.bits)) if self.kind == "numpy" else float(q)
        return self.dtype.type(r) if self.kind == "numpy" else r

    def exact(self, q):
        """``q`` (any number) as a working value; ValueError unless representable."""
        f = to_fraction(q)
        w = self.from_fraction(f)
        if self.to_fraction(w) != f:
            raise ValueError(f"{q!r} is not representable in {self.name}; round the "
                             "inputs first (the analysis assumes exact coordinates)")
        return w

    def to_fraction(self, w) -> Fraction:
        if self.kind == "mp":
            return mp_to_fraction(w)
        return Fraction(float(w))

    def round(self, q, mode: str = "z") -> Fraction:
        """``q`` rounded to this format's significand (exponent range ignored)."""
        return round_to_bits(Fraction(q), self.bits, mode)

    def ulp(self, q) -> Fraction:
        """The spacing of this format's numbers at ``q`` (q ≠ 0; exponent range ignored)."""
        a = abs(Fraction(q))
        n, d = a.numerator, a.denominator
        e = n.bit_length() - d.bit_length()
        if (n << max(-e, 0)) < (d << max(e, 0)):
            e -= 1
        k = e - self.bits + 1
        return Fraction(1 << k) if k >= 0 else Fraction(1, 1 << -k)

    def is_array(self, w) -> bool:
        return isinstance(w, np.ndarray)


def to_fraction(v) -> Fraction:
    """The exact value of a float, numpy scalar, mpf, int or Fraction."""
    if type(v) is Fraction:
        return v
    if isinstance(v, mpmath.mpf):
        return mp_to_fraction(v)
    if isinstance(v, (np.floating, np.integer)):
        return Fraction(v.item())
    if isinstance(v, (int, float, str)):
        return Fraction(v)
    raise TypeError(f"no exact value for {v!r}")


#: Python floats (binary64, ε = 2^-53).
BINARY64 = WorkingFormat("binary64", "float", 53, min_normal=Fraction(2) ** -1022)
#: numpy float32 (binary32, ε = 2^-24).
BINARY32 = WorkingFormat("binary32", "numpy", 24, np.float32, min_normal=Fraction(2) ** -126)
#: numpy float64 scalars/arrays (binary64).
NP_BINARY64 = WorkingFormat("np.float64", "numpy", 53, np.float64,
                            min_normal=Fraction(2) ** -1022)


def mp_format(prec: int) -> WorkingFormat:
    """mpmath at ``prec`` bits (ε = 2^-prec); ``mp_format(17)`` is the paper's worst case."""
    return WorkingFormat(f"mp{prec}", "mp", prec)


# --------------------------------------------------------------------------------------
# the shadow number
# --------------------------------------------------------------------------------------
class Shadow:
    """A working value ``w``, its exact value ``x`` and, for tolerance-dependent quantities,
    the exact values ``lo``/``hi`` with T−/T+ substituted (see module docstring)."""

    __slots__ = ("w", "x", "lo", "hi", "fmt", "label")
    __array_priority__ = 1000

    def __init__(self, w, x, fmt: WorkingFormat, lo=None, hi=None, label=None):
        self.w = w
        self.x = x
        self.fmt = fmt
        self.lo = lo
        self.hi = hi
        self.label = label

    # construction -------------------------------------------------------------------
    @classmethod
    def exact_input(cls, value, fmt: WorkingFormat, label=None) -> "Shadow":
        """An input (e.g. a coordinate) that the working format holds exactly."""
        if isinstance(value, np.ndarray):
            w = np.asarray(value, dtype=fmt.dtype)
            x = np.empty(w.shape, dtype=object)
            x.flat[:] = [Fraction(v) for v in w.astype(np.float64).ravel()]
            if any(Fraction(float(a)) != b for a, b in zip(np.asarray(value).ravel(), x.ravel())):
                raise ValueError(f"input {label} is not representable in {fmt.name}")
            return cls(w, x, fmt, label=label)
        return cls(fmt.exact(value), to_fraction(value), fmt, label=label)

    @classmethod
    def bracketed(cls, w, x, lo, hi, fmt: WorkingFormat, label=None) -> "Shadow":
        """A tolerance: working value ``w``, exact value ``x`` (T), brackets T−, T+."""
        return cls(w, x, fmt, lo, hi, label)

    def _lift(self, o):
        if isinstance(o, Shadow):
            return o
        if isinstance(o, (int, float, Fraction, np.floating, np.integer, mpmath.mpf)) \
                and not isinstance(o, bool):
            q = to_fraction(o)
            return Shadow(self.fmt.from_fraction(q), q, self.fmt, label=_num_label(q))
        return NotImplemented

    # arithmetic ---------------------------------------------------------------------
    def _bin(self, o, op, wop, xop, vxop, reflected=False):
        if type(o) is not Shadow:
            o = self._lift(o)
            if o is NotImplemented:
                return NotImplemented
        a, b = (o, self) if reflected else (self, o)
        ax, bx = a.x, b.x
        if type(ax) is Fraction and type(bx) is Fraction:
            f = xop
        else:
            f = vxop if (type(ax) is np.ndarray or type(bx) is np.ndarray) else xop
        x = f(ax, bx)
        if a.lo is None and b.lo is None:
            lo = hi = None
        else:
            lo = f(ax if a.lo is None else a.lo, bx if b.lo is None else b.lo)
            hi = f(ax if a.hi is None else a.hi, bx if b.hi is None else b.hi)
        label = f"({a.label}{op}{b.label})" if (a.label and b.label) else None
        return Shadow(wop(a.w, b.w), x, a.fmt, lo, hi, label)

    def __add__(self, o): return self._bin(o, "+", _wadd, _add, _vadd)
    def __radd__(self, o): return self._bin(o, "+", _wadd, _add, _vadd, True)
    def __sub__(self, o): return self._bin(o, "-", _wsub, _sub, _vsub)
    def __rsub__(self, o): return self._bin(o, "-", _wsub, _sub, _vsub, True)
    def __mul__(self, o): return self._bin(o, "*", _wmul, _mul, _vmul)
    def __rmul__(self, o): return self._bin(o, "*", _wmul, _mul, _vmul, True)
    def __truediv__(self, o): return self._bin(o, "/", _wdiv, _div, _vdiv)
    def __rtruediv__(self, o): return self._bin(o, "/", _wdiv, _div, _vdiv, True)

    def _un(self, wop, xop, vxop, label):
        f = vxop if isinstance(self.x, np.ndarray) else xop
        lo = None if self.lo is None else f(self.lo)
        hi = None if self.hi is None else f(self.hi)
        return Shadow(wop(self.w), f(self.x), self.fmt, lo, hi, label)

    def __neg__(self):
        return self._un(_wneg, _neg, _vneg, f"(-{self.label})" if self.label else None)

    def __pos__(self):
        return self

    def __abs__(self):
        return self._un(abs, _abs, _vabs, f"|{self.label}|" if self.label else None)

    def sqrt(self) -> "Shadow":
        return self._un(self.fmt.sqrt, exact_sqrt, _vsqrt,
                        f"sqrt({self.label})" if self.label else None)

    def __pow__(self, k):
        if not isinstance(k, int) or isinstance(k, bool) or k < 1:
            raise TypeError("Shadow ** k needs an integer k >= 1 (written as products)")
        out = self
        for _ in range(k - 1):
            out = out * self
        return out

    # comparisons: records --------------------------------------------------------------
    def _cmp(self, o, rel):
        o = self._lift(o)
        if o is NotImplemented:
            return NotImplemented
        return ShadowCheck(self, o, rel)

    def __le__(self, o): return self._cmp(o, "<=")
    def __lt__(self, o): return self._cmp(o, "<")
    def __ge__(self, o): return self._cmp(o, ">=")
    def __gt__(self, o): return self._cmp(o, ">")

    def __bool__(self):
        raise TypeError("the truth value of a Shadow is a decision: route it through a "
                        "context (ctx.reject / ctx.any)")

    __hash__ = object.__hash__

    # measurements ----------------------------------------------------------------------
    @property
    def working_fraction(self) -> Fraction:
        """The working value's exact (dyadic) value (scalars only)."""
        return self.fmt.to_fraction(self.w)

    def error(self) -> Fraction | None:
        """|F[x] − x| exactly, or an upper bound of it when x is an interval (scalars)."""
        if self.x is None:
            return None
        return upper_fraction(_sub(self.working_fraction, self.x))

    def __repr__(self):
        x = self.x
        xs = (f"{float(x):.17g}" if type(x) is Fraction else
              ("undefined" if x is None else f"{float(x):.17g} (interval)"))
        return f"Shadow({self.label or '?'}: F = {self.w!r}, exact = {xs})"


def _num_label(q: Fraction) -> str:
    return str(q.numerator) if q.denominator == 1 else str(q)


def _wadd(a, b): return a + b
def _wsub(a, b): return a - b
def _wmul(a, b): return a * b
def _wdiv(a, b): return a / b
def _wneg(a): return -a


_REL = {"<=": lambda a, b: a <= b, "<": lambda a, b: a < b,
        ">=": lambda a, b: a >= b, ">": lambda a, b: a > b}
_REL_CMP = {"<=": (-1, 0), "<": (-1,), ">=": (1, 0), ">": (1,)}


class ShadowCheck:
    """A comparison ``lhs rel rhs`` of shadow numbers: the working decision and the exact
    decisions with T (``"mid"``), T− (``"lo"``) or T+ (``"hi"``) substituted."""

    __slots__ = ("lhs", "rhs", "rel", "line", "label", "index", "active")

    def __init__(self, lhs: Shadow, rhs: Shadow, rel: str, label: str = ""):
        self.lhs, self.rhs, self.rel = lhs, rhs, rel
        self.line = None
        self.label = label
        self.index = None
        self.active = None  # lane mask when recorded (array working values)

    def __bool__(self):
        raise TypeError("a shadow comparison decides nothing by itself; pass it to the "
                        "context (ctx.reject / ctx.any)")

    @property
    def decision(self):
        """The working-precision decision (bool, or a bool array)."""
        return _REL[self.rel](self.lhs.w, self.rhs.w)

    @property
    def bracketed(self) -> bool:
        """True when the right-hand side depends on a tolerance (has T−/T+ values)."""
        return self.rhs.lo is not None

    @property
    def is_sign_test(self) -> bool:
        """A comparison against the constant zero."""
        r = self.rhs
        return r.lo is None and type(r.x) is Fraction and r.x == 0

    def rhs_exact(self, which: str = "mid"):
        r = self.rhs
        if which == "mid" or r.lo is None:
            return r.x
        lo, hi = (r.lo, r.hi)
        return lo if which == "lo" else hi

    def lhs_exact(self, which: str = "mid"):
        l = self.lhs
        if which == "mid" or l.lo is None:
            return l.x
        return l.lo if which == "lo" else l.hi

    def exact_decision(self, which: str = "mid"):
        """The exact decision with T (mid), T− (lo) or T+ (hi); None when undecided."""
        a, b = self.lhs_exact(which), self.rhs_exact(which)
        if _arr(a, b):
            c = _vcmp(a, b)
            ok = _REL_CMP[self.rel]
            return np.array([None if v is None else (v in ok) for v in np.ravel(c)],
                            dtype=object).reshape(np.shape(c))
        c = compare(a, b)
        return None if c is None else (c in _REL_CMP[self.rel])

    def __str__(self):
        where = f" (line {self.line})" if self.line is not None else ""
        return (self.label or f"{self.lhs.label or '?'} {self.rel} {self.rhs.label or '?'}") + where

    __repr__ = __str__


class _Any:
    __slots__ = ("conds",)

    def __init__(self, conds):
        self.conds = conds

    def __bool__(self):
        raise TypeError("route decisions through the context")


class _Sign:
    __slots__ = ("x", "y", "same", "leaves")

    def __init__(self, x, y, same):
        self.x, self.y, self.same = x, y, same
        zero = x._lift(0)
        self.leaves = [ShadowCheck(x, zero, ">", "sign"), ShadowCheck(y, zero, ">", "sign")]

    def __bool__(self):
        raise TypeError("route decisions through the context")


# --------------------------------------------------------------------------------------
# the context
# --------------------------------------------------------------------------------------
class ShadowContext(Context):
    """Runs a predicate on :class:`Shadow` numbers, following the working decisions.

    After a run: ``quantities`` (label → Shadow, in order of computation),
    ``checks`` (every leaf comparison, in the order the instrumented run records them,
    with ``line``), ``rejects`` (line, working decision of the whole condition),
    ``weights`` and ``result`` (the working result: True/False, or a lane mask).

    Scalar inputs: an early return ends the run, as in :class:`fperr.FloatContext`.
    Array inputs (``lanes``): rejected lanes are masked as in
    :class:`fperr.NumpyContext`; ``active_at[label]`` holds the lanes still on the path
    when a quantity was computed, and each check's ``active`` mask likewise.
    """

    def __init__(self, fmt: WorkingFormat = BINARY64):
        self.fmt = fmt
        self.eps = float(fmt.eps)
        self.quantities: dict[str, Shadow] = {}
        self.active_at: dict[str, np.ndarray] = {}
        self.checks: list[ShadowCheck] = []
        self.rejects: list = []
        self.weights: tuple = ()
        self.result = None
        self.active = None

    def fresh(self, n_weights, lanes=None):
        c = ShadowContext(self.fmt)
        c.n_weights = n_weights
        if lanes is not None:
            c.active = np.ones(lanes, dtype=bool)
        return c

    @contextmanager
    def session(self):
        with self.fmt.session():
            yield self

    def name(self, label, x):
        if isinstance(x, Shadow):
            x.label = label
            self.quantities[label] = x
            if self.active is not None:
                self.active_at[label] = self.active.copy()
        return x

    def const(self, x):
        q = to_fraction(x) if not isinstance(x, str) else Fraction(x)
        return Shadow(self.fmt.from_fraction(q), q, self.fmt, label=_num_label(q))

    def sqrt(self, x):
        if not isinstance(x, Shadow):
            x = self.const(x)
        return x.sqrt()

    def coords(self, point, label):
        out = []
        for k, v in enumerate(point):
            out.append(v if isinstance(v, Shadow)
                       else Shadow.exact_input(v, self.fmt, f"{label}.{'xyzw'[k]}"))
        return tuple(out)

    # decisions --------------------------------------------------------------------------
    def _leaves(self, cond):
        if isinstance(cond, ShadowCheck):
            return [cond]
        if isinstance(cond, _Sign):
            return list(cond.leaves)
        if isinstance(cond, _Any):
            return [c for x in cond.conds for c in self._leaves(x)]
        if isinstance(cond, (list, tuple)):
            return [c for x in cond for c in self._leaves(x)]
        raise TypeError(f"a shadow condition must be a Shadow comparison, got {cond!r}")

    def _decide(self, cond):
        if isinstance(cond, ShadowCheck):
            return cond.decision
        if isinstance(cond, _Sign):
            px, py = cond.leaves[0].decision, cond.leaves[1].decision
            return (px == py) if cond.same else (px != py)
        if isinstance(cond, _Any):
            out = False
            for c in cond.conds:
                out = out | self._decide(c)
            return out
        if isinstance(cond, (list, tuple)):
            return self._decide(_Any(cond))
        raise TypeError(f"a shadow condition must be a Shadow comparison, got {cond!r}")

    def reject(self, cond, line=None) -> bool:
        d = self._decide(cond)
        for c in self._leaves(cond):
            c.line = line
            c.index = len(self.checks)
            if self.active is not None:
                c.active = self.active.copy()
            self.checks.append(c)
        self.rejects.append((line, d))
        if self.active is None:
            return bool(d)
        self.active &= ~np.asarray(d, dtype=bool)
        return not self.active.any()

    def any(self, *conds):
        return _Any(list(conds))

    def same_sign(self, x, y):
        return _Sign(x, y, True)

    def differ_sign(self, x, y):
        return _Sign(x, y, False)

    def hit(self, weights):
        self.weights = tuple(weights)
        self.result = True if self.active is None else self.active.copy()
        return self.result, self.weights

    def miss(self):
        self.result = False if self.active is None else np.zeros_like(self.active)
        return self.result, ()
