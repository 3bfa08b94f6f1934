"""Shadow execution: a number that carries its working-precision value *and* its exact value.

A :class:`Shadow` holds

* ``w`` — the value the real floating-point path computes in a working context ``fmt``
  (:class:`fperr.FloatContext`, a :class:`fperr.NumpyContext` scalar or array, an
  :class:`fperr.MpContext` ``mpf``; any :func:`fperr.context`);
* ``x`` — the exact value of the same expression on the same (exact) inputs: a Fraction
  or a rigorous interval (see :mod:`fperr.intervals`);
* ``lo`` / ``hi`` — for quantities computed from a *bracketed* input (a tolerance T with
  its exact brackets T− and T+, section 3 of the paper): the exact value with T− resp.
  T+ substituted for T. ``None`` for quantities that do not depend on a tolerance.

Operators act on all parts at once. A :class:`ShadowContext` runs a predicate written
against :class:`fperr.Context` with shadow numbers: it follows the **working** value's
decisions (so the real floating-point path runs, early returns included) and records every
named quantity and every comparison, whose exact decisions at T, T− and T+ can then be
read from the record (:meth:`ShadowCheck.exact_decision`).

This module knows nothing of geometry; :mod:`proofs.audit` uses it to audit the
predicates.
"""
from __future__ import annotations

from contextlib import contextmanager
from fractions import Fraction

import mpmath
import numpy as np

from .contexts import Context, FloatContext
from .exact import to_fraction
from .intervals import (compare, exact_abs, exact_add, exact_div, exact_mul, exact_neg,
                        exact_sqrt, exact_sub, upper_fraction)

__all__ = ["Shadow", "ShadowCheck", "ShadowContext"]


# vectorised versions for object arrays (array working values)
_vadd = np.frompyfunc(exact_add, 2, 1)
_vsub = np.frompyfunc(exact_sub, 2, 1)
_vmul = np.frompyfunc(exact_mul, 2, 1)
_vdiv = np.frompyfunc(exact_div, 2, 1)
_vneg = np.frompyfunc(exact_neg, 1, 1)
_vabs = np.frompyfunc(exact_abs, 1, 1)
_vsqrt = np.frompyfunc(exact_sqrt, 1, 1)
_vcmp = np.frompyfunc(compare, 2, 1)


def _arr(*xs):
    return any(isinstance(x, np.ndarray) for x in xs)


# --------------------------------------------------------------------------------------
# the shadow number
# --------------------------------------------------------------------------------------
class Shadow:
    """A working value ``w``, its exact value ``x`` and, for tolerance-dependent quantities,
    the exact values ``lo``/``hi`` with T−/T+ substituted (see module docstring)."""

    __slots__ = ("w", "x", "lo", "hi", "fmt", "label")
    __array_priority__ = 1000

    def __init__(self, w, x, fmt: Context, lo=None, hi=None, label=None):
        self.w = w
        self.x = x
        self.fmt = fmt
        self.lo = lo
        self.hi = hi
        self.label = label

    # construction -------------------------------------------------------------------
    @classmethod
    def exact_input(cls, value, fmt: Context, label=None) -> "Shadow":
        """An input (e.g. a coordinate) that the working format holds exactly."""
        if isinstance(value, np.ndarray):
            w = np.asarray(value, dtype=fmt.dtype)
            x = np.empty(w.shape, dtype=object)
            x.flat[:] = [Fraction(v) for v in w.astype(np.float64).ravel()]
            if any(Fraction(float(a)) != b for a, b in zip(np.asarray(value).ravel(), x.ravel())):
                raise ValueError(f"input {label} is not representable in {fmt.format}")
            return cls(w, x, fmt, label=label)
        return cls(fmt.convert(value), to_fraction(value), fmt, label=label)

    @classmethod
    def bracketed(cls, w, x, lo, hi, fmt: Context, label=None) -> "Shadow":
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

    def __add__(self, o): return self._bin(o, "+", _wadd, exact_add, _vadd)
    def __radd__(self, o): return self._bin(o, "+", _wadd, exact_add, _vadd, True)
    def __sub__(self, o): return self._bin(o, "-", _wsub, exact_sub, _vsub)
    def __rsub__(self, o): return self._bin(o, "-", _wsub, exact_sub, _vsub, True)
    def __mul__(self, o): return self._bin(o, "*", _wmul, exact_mul, _vmul)
    def __rmul__(self, o): return self._bin(o, "*", _wmul, exact_mul, _vmul, True)
    def __truediv__(self, o): return self._bin(o, "/", _wdiv, exact_div, _vdiv)
    def __rtruediv__(self, o): return self._bin(o, "/", _wdiv, exact_div, _vdiv, True)

    def _un(self, wop, xop, vxop, label):
        f = vxop if isinstance(self.x, np.ndarray) else xop
        lo = None if self.lo is None else f(self.lo)
        hi = None if self.hi is None else f(self.hi)
        return Shadow(wop(self.w), f(self.x), self.fmt, lo, hi, label)

    def __neg__(self):
        return self._un(_wneg, exact_neg, _vneg, f"(-{self.label})" if self.label else None)

    def __pos__(self):
        return self

    def __abs__(self):
        return self._un(abs, exact_abs, _vabs, f"|{self.label}|" if self.label else None)

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
        return upper_fraction(exact_sub(self.working_fraction, self.x))

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

    def __init__(self, fmt: Context | None = None):
        self.fmt = fmt = FloatContext() if fmt is None else fmt
        self.format = f"shadow:{fmt.format}"
        self.eps, self.bits, self.dtype = fmt.eps, fmt.bits, fmt.dtype
        self.min_normal, self.max_finite = fmt.min_normal, fmt.max_finite
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
        return self.from_fraction(to_fraction(x))

    # number-type decisions: the working format's, with the exact value alongside ------
    def from_fraction(self, q, rounding: str = "nearest") -> Shadow:
        q = to_fraction(q)
        return Shadow(self.fmt.from_fraction(q, rounding), q, self.fmt, label=_num_label(q))

    def to_fraction(self, x) -> Fraction:
        """The exact value of the working value of a scalar :class:`Shadow`."""
        return x.working_fraction

    def convert(self, x) -> Shadow:
        return x if isinstance(x, Shadow) else Shadow.exact_input(x, self.fmt)

    def eps_multiple(self, q, power: int = 1) -> Shadow:
        return self.const(Fraction(q) * Fraction(1, 2 ** self.bits) ** power)

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
