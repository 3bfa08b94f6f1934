"""``Tracked``: a number whose state is the paper's (s, c, p, n, a, b, r, v).

Operators apply rules A–K (section 2, see :mod:`fperr.rules`). State arithmetic is
exact (sympy); ε appears as a symbol only where a magnitude depends on it
(tolerances). Comparisons do not decide anything: they return a
:class:`fperr.checks.Check` record, and ``bool()`` of a Tracked or a Check raises, so a
predicate cannot branch on a Tracked behind its context's back.
"""
from __future__ import annotations

from fractions import Fraction
from typing import Iterator

import sympy

from . import ops, rules
from .exact import is_exact, to_fraction
from .rules import InvalidBound, NoRule, State  # noqa: F401  (InvalidBound: re-exported)


class Tracked:
    """A quantity with the paper's floating-point error state.

    Attributes: ``s`` (canonical string of the computation), ``state`` (c, p, n, a, b,
    r; None when invalid), ``v`` (valid), ``rule`` (the rule ID that produced it),
    ``args`` (operands), ``why`` (reason when invalid), ``inv`` (a quotient: rule G's
    c = 1 is a convention, not a bound, until it is multiplied into a normalised
    quantity), ``unit_of`` (for a quotient 1/‖v‖: the strings of v's components, the
    only factors whose product with it has |x| ≤ 1).
    """

    __slots__ = ("s", "state", "rule", "args", "why", "inv", "name", "unit_of")
    __array_priority__ = 1000  # so numpy scalars defer to our reflected operators

    def __init__(self, s: str, state: State | None, rule: str, args: tuple = (),
                 why: str = "", inv: bool = False, name: str | None = None):
        self.s = s
        self.state = state
        self.rule = rule
        self.args = args
        self.why = why
        self.inv = inv
        self.name = name
        self.unit_of: frozenset = frozenset()

    # -- the paper's fields -------------------------------------------------
    @property
    def v(self) -> bool:
        return self.state is not None

    def _field(self, f):
        if self.state is None:
            raise InvalidBound(f"{self.label} is invalid: {self.why}")
        return getattr(self.state, f)

    c = property(lambda self: self._field("c"))
    p = property(lambda self: self._field("p"))
    n = property(lambda self: self._field("n"))
    a = property(lambda self: self._field("a"))
    b = property(lambda self: self._field("b"))
    r = property(lambda self: self._field("r"))

    @property
    def label(self) -> str:
        return self.name or self.s

    # -- construction ---------------------------------------------------------
    @staticmethod
    def _invalid(s, rule, args, why) -> "Tracked":
        return Tracked(s, None, rule, args, why)

    @staticmethod
    def _apply(s: str, candidates, args, fn_args) -> "Tracked":
        bad = [x for x in args if not x.v]
        if bad:
            return Tracked._invalid(s, candidates[0], args, f"operand {bad[0].label} is invalid")
        errors = []
        for rid in candidates:
            try:
                st = getattr(rules, "rule_" + rid)(*fn_args)
            except NoRule as e:
                errors.append(str(e))
                continue
            return Tracked(s, _simplify(st), rid, args)
        return Tracked._invalid(s, candidates[-1], args, "; ".join(errors))

    # -- operators (installed from fperr.ops.OPS below) ---------------------------------
    def _unary(self, op: str) -> "Tracked":
        o = ops.OPS[op]
        s = o.s_form.format(self.s)
        if self.v and self.inv:
            return self._invalid(s, o.rules[0], (self,), _INV_MSG)
        return self._apply(s, o.rules, (self,), (self.state,))

    def __pos__(self) -> "Tracked":
        return self

    def _binary(self, other, op: str, reflected: bool = False) -> "Tracked":
        other = _lift(other)
        if other is NotImplemented:
            return NotImplemented
        x, y = (other, self) if reflected else (self, other)
        o = ops.OPS[op]
        s = o.s_form.format(x.s, y.s)
        if op in "+-":
            if x.inv or y.inv:
                return self._invalid(s, o.rules[-1], (x, y), _INV_MSG)
            return self._apply(s, o.rules, (x, y), (x.state, y.state))
        scaled = _power_of_two_scaling(s, op, x, y)
        if scaled is not None:
            return scaled
        if op == "*":
            if x.inv and y.inv:
                return self._invalid(s, "F", (x, y), _INV_MSG)
            q, f = (x, y) if x.inv else (y, x)
            if q.inv and f.s not in q.unit_of:
                return self._invalid(s, "F", (x, y), _INV_MSG)
            out = self._apply(s, o.rules, (x, y), (x.state, y.state, x.s == y.s))
            if out.v and q.inv:
                # Rule G's "*": v_i·(1/‖v‖) is a component of a unit vector, c = 1.
                st = out.state
                out.state = State(sympy.Integer(1), st.p, st.n, st.a, st.b, st.r)
            return out
        if op == "/":
            if x.inv or y.inv:
                return self._invalid(s, "G", (x, y), _INV_MSG)
            out = self._apply(s, o.rules, (x, y), (x.state, y.state))
            out.inv = out.v
            if out.v and x.rule == "J" and x.c == 1:
                out.unit_of = _norm_components(y)
            return out
        raise AssertionError(op)

    def __pow__(self, k):
        """x**k for an integer k ≥ 1 is evaluated as repeated multiplication, left to right."""
        if not isinstance(k, int) or isinstance(k, bool) or k < 1:
            raise TypeError("Tracked ** k needs an integer k >= 1 (written as products)")
        out = self
        for _ in range(k - 1):
            out = out * self
        return out

    # -- comparisons: records, not decisions -------------------------------------
    def _check(self, other, rel):
        from .checks import Check
        other = _lift(other)
        if other is NotImplemented:
            return NotImplemented
        return Check(self, other, rel)

    def __le__(self, o): return self._check(o, "<=")
    def __lt__(self, o): return self._check(o, "<")
    def __ge__(self, o): return self._check(o, ">=")
    def __gt__(self, o): return self._check(o, ">")

    def __bool__(self):
        raise TypeError(f"the truth value of Tracked {self.label} is undecided; "
                        "route decisions through a predicate context")

    __hash__ = object.__hash__

    # -- display ----------------------------------------------------------------
    def __repr__(self) -> str:
        if not self.v:
            return f"Tracked({self.label!r}, invalid: {self.why})"
        st = self.state
        flags = "".join(f for f, on in (("n", st.n), ("r", st.r)) if on)
        return (f"Tracked({self.label!r}, rule {self.rule}, c={st.c}, p={st.p}, "
                f"a={st.a}, b={st.b}, flags={flags or '-'})")

    def walk(self) -> Iterator["Tracked"]:
        """Every quantity this one was computed from, operands first, each once."""
        seen: set[int] = set()
        stack = [(self, False)]
        while stack:
            x, done = stack.pop()
            if id(x) in seen:
                continue
            if done or not x.args:
                seen.add(id(x))
                yield x
            else:
                stack.append((x, True))
                stack.extend((a, False) for a in reversed(x.args) if id(a) not in seen)

    def derivation(self) -> str:
        """One line per step, operands first: ``t3 = t1 - t2  [E] c=1 p=1 a=1 b=0 r``.

        Inputs show their name; named quantities (``ctx.name``) show it after the step.
        """
        ids: dict[int, str] = {}
        lines = []
        for x in self.walk():
            tag = ids[id(x)] = f"t{len(ids) + 1}"
            if not x.args:
                expr = x.s
            else:
                expr = ops.BY_RULE[x.rule].text.format(*(ids[id(a)] for a in x.args))
            if not x.v:
                body = f"invalid: {x.why}"
            else:
                st = x.state
                flags = " ".join(f for f, on in (("n", st.n), ("r", st.r)) if on)
                body = f"c={st.c} p={st.p} a={st.a} b={st.b} {flags}".rstrip()
                body += "  [c=1*]" if x.inv else ""
            named = f"  ({x.name})" if x.name and x.args else ""
            lines.append(f"{tag} = {expr:<18} [{x.rule}] {body}{named}")
        return "\n".join(lines)


def _install_operators() -> None:
    """The dunders of :class:`Tracked` (reflected ones too), from the operator table."""
    for op in ops.OPS.values():
        if op.dunder is None:
            continue
        if op.arity == 1:
            setattr(Tracked, f"__{op.dunder}__", lambda self, k=op.key: self._unary(k))
            continue
        setattr(Tracked, f"__{op.dunder}__", lambda self, o, k=op.key: self._binary(o, k))
        setattr(Tracked, f"__r{op.dunder}__",
                lambda self, o, k=op.key: self._binary(o, k, True))


_install_operators()

_INV_MSG = ("a quotient (rule G, c = 1*) may only be multiplied by a component v_i of the "
            "vector v it normalises (1/‖v‖); no magnitude bound holds otherwise")


def _norm_components(m: "Tracked") -> frozenset:
    """The strings of v's components when m = sqrt(v_1·v_1 + ... + v_k·v_k), else empty."""
    if m.rule != "H" or not m.args:
        return frozenset()
    comps, stack = set(), [m.args[0]]
    while stack:
        t = stack.pop()
        if t.rule in ("B", "C") and len(t.args) == 2:
            stack.extend(t.args)
        elif t.rule == "F" and t.args[0].s == t.args[1].s:
            comps.add(t.args[0].s)
        else:
            return frozenset()
    return frozenset(comps)


def _simplify(st: State) -> State:
    f = lambda e: sympy.nsimplify(e) if isinstance(e, sympy.Float) else sympy.radsimp(e)
    return State(f(st.c), sympy.nsimplify(st.p), st.n, f(st.a), f(st.b), st.r)


def _lift(x):
    if isinstance(x, Tracked):
        return x
    try:
        return const(x)
    except (TypeError, ValueError):
        return NotImplemented


def coord(name: str) -> Tracked:
    """Rule K: an input coordinate, exact, magnitude L/2."""
    return Tracked(name, rules.rule_K(), "K")


def exact_input(name: str, c=1, p=1, nonnegative: bool = False) -> Tracked:
    """An exact input of magnitude c·L^p (rule K generalised: e.g. the scale L itself)."""
    st = State(sympy.sympify(c), sympy.sympify(p), nonnegative,
               sympy.Integer(0), sympy.Integer(0), True)
    return Tracked(name, st, "K")


def const(x, exact: bool | None = None, name: str | None = None) -> Tracked:
    """Rule J: a numeric constant.

    ``x`` may be an int, Fraction, float, decimal string ("0.1"), or a sympy expression
    (possibly in ``eps``: ``const(21*eps)``). It is exact when every format the analysis
    covers (significand ≥ 17 bits) holds it (see :mod:`fperr.exact`); otherwise it is
    rounded once on entry and carries a = 1. ``exact=True`` refuses an inexact constant
    instead; ``exact=False`` forces the rounding error.
    """
    value = sympy.sympify(x) if not isinstance(x, (int, float, Fraction, str)) else None
    if value is None:
        q = to_fraction(x)
        value = sympy.Rational(q.numerator, q.denominator)
    representable = _representable(value)
    if exact and not representable:
        raise ValueError(f"constant {x!r} is not exactly representable in a 17-bit format")
    use_exact = representable if exact is None else (exact and representable)
    s = name or _const_string(value)
    return Tracked(s, rules.rule_J(value, use_exact), "J")


def _power_of_two(t: "Tracked"):
    """±2^k (a sympy Rational) when ``t`` is an exact rule-J constant of that value."""
    if t.rule != "J" or not t.v or t.inv or t.a != 0 or t.b != 0:
        return None
    try:
        value = sympy.Rational(sympy.sympify(t.s))
    except (TypeError, ValueError, sympy.SympifyError):
        return None
    m = abs(value)
    if m == 0 or (m.p & (m.p - 1)) or (m.q & (m.q - 1)):
        return None
    return value


def _power_of_two_scaling(s: str, op: str, x: "Tracked", y: "Tracked"):
    """Rules P/Q: x·2^k, 2^k·y or x/2^k with an exact constant 2^k cost no rounding."""
    if x.inv or y.inv or not (x.v and y.v):
        return None
    if op == "/" and (f := _power_of_two(y)) is not None:
        return Tracked._apply(s, ("Q",), (x, y), (x.state, y.state, f))
    if op == "*":
        for t, c in ((x, y), (y, x)):
            if (f := _power_of_two(c)) is not None and t.rule != "J":
                return Tracked._apply(s, ("P",), (x, y), (t.state, c.state, f))
    return None


def _representable(value: sympy.Expr) -> bool:
    """Exact when value = q·ε^k with q a short dyadic and k an integer (ε is a power of 2)."""
    from .symbols import eps
    coeff, rest = value.as_coeff_Mul()
    if rest != 1:
        powers = rest.as_powers_dict()
        if set(powers) != {eps} or not sympy.sympify(powers[eps]).is_integer:
            return False
    coeff = sympy.nsimplify(coeff) if coeff.is_Float else coeff
    return bool(coeff.is_Rational) and is_exact(to_fraction(coeff))


def _const_string(v: sympy.Expr) -> str:
    return str(v) if v.is_Atom else f"[{v}]"


def sqrt(x) -> Tracked:
    """Rule H: the square root of a non-negative quantity with relative error."""
    x = _lift(x)
    return x._unary("sqrt")
