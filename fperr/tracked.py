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

from . import guards, ops, rules
from .exact import is_exact, to_fraction
from .rules import InvalidBound, NoRule, State  # noqa: F401  (InvalidBound: re-exported)
from .state import EpsFrac


class Tracked:
    """A quantity with the paper's floating-point error state.

    Attributes: ``s`` (canonical string of the computation), ``state`` (c, p, n, a, b,
    r; None when invalid), ``v`` (valid), ``rule`` (the rule ID that produced it),
    ``args`` (operands), ``why`` (reason when invalid), ``inv`` (a quotient: rule G's
    c = 1 is a convention, not a bound, until it is multiplied into a normalised
    quantity), ``unit_of`` (for a quotient 1/‖v‖: the keys of v's components, the
    only factors whose product with it has |x| ≤ 1), ``key`` (an integer equal for equal
    texts ``s``: the same computation of the same leaves).
    """

    __slots__ = ("_s", "key", "state", "rule", "args", "why", "inv", "name", "unit_of",
                 "tight", "floor", "sign_link", "premises")
    __array_priority__ = 1000  # so numpy scalars defer to our reflected operators

    def __init__(self, s: str | None, state: State | None, rule: str, args: tuple = (),
                 why: str = "", inv: bool = False, name: str | None = None):
        # s: a leaf's name; None for an operation, whose text is built on demand
        self._s = s
        self.key = _intern(("leaf", s) if s is not None else
                           (ops.BY_RULE[rule].key, *(a.key for a in args)))
        self.state = state
        self.rule = rule
        self.args = args
        self.why = why
        self.inv = inv
        self.name = name
        self.unit_of: frozenset = frozenset()
        # tight: the exact value is exactly c·L^p (constants, L^p, tolerances), so a
        # passed check x > t bounds x below by t's value (guards.py);
        # floor: |F[x]| > floor·L^p holds wherever x is used (a passed check, guards.py);
        # sign_link: (other, parity): x's computed sign equals (parity 0) or is opposite
        # to (parity 1) other's (a rejected same/differ-sign test, guards.py).
        self.tight = False
        self.floor = None
        self.sign_link = None
        # premises: ((d, k), ...): this state holds if F[d]'s floor f satisfies
        # f·L^p > k·E[d] (rules GL, HL: k = 1, the exact |d| > 0; the verifier checks)
        self.premises: tuple = ()

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

    @property
    def s(self) -> str:
        """The canonical text of the computation ("((x0*x1)-(x2*x3))"), built on demand
        (iteratively) from the operations: no state holds it, so a long computation
        costs memory linear in its operations, not in the lengths of its texts."""
        return self._s if self._s is not None else _text(self)

    @s.setter
    def s(self, text: str) -> None:
        """Name a quantity as a leaf of later texts (the tolerances: "sigma")."""
        self._s = text
        self.key = _intern(("leaf", text))

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
        s = None  # the text is built on demand (Tracked.s)
        if self.v and self.inv:
            return self._invalid(s, o.rules[0], (self,), _INV_MSG)
        if op == "sqrt":
            out = self._apply(s, ("H",), (self,), (self.state,))
            if not out.v and self.v and self.floor is not None:
                out = self._apply(s, ("HL",), (self,), (self.state, self.floor))
                out.rule = out.rule if out.v else "H"
                out.premises = ((self, 1),) if out.v else ()
            out.tight = self.tight and out.v
            return out
        out = self._apply(s, o.rules, (self,), (self.state,))
        guards.after_unary(out, self, op)
        return out

    def __pos__(self) -> "Tracked":
        return self

    def _binary(self, other, op: str, reflected: bool = False) -> "Tracked":
        other = _lift(other)
        if other is NotImplemented:
            return NotImplemented
        x, y = (other, self) if reflected else (self, other)
        o = ops.OPS[op]
        s = None  # the text is built on demand (Tracked.s)
        if op in "+-":
            if x.inv or y.inv:
                return self._invalid(s, o.rules[-1], (x, y), _INV_MSG)
            out = self._apply(s, o.rules, (x, y), (x.state, y.state))
            guards.after_sum(out, x, y, op)
            return out
        if op == "*":
            return self._product(s, x, y)
        if op == "/":
            return self._quotient(s, x, y)
        raise AssertionError(op)

    def _product(self, s: str, x: "Tracked", y: "Tracked") -> "Tracked":
        if x.inv and y.inv:
            return self._invalid(s, "F", (x, y), _INV_MSG)
        q, f = (x, y) if x.inv else (y, x)
        scale = guards.power_of_two(y) or guards.power_of_two(x)
        if scale and not q.inv:  # rule S: ·2^k is exact (rules.rule_S)
            k, v = (x, y) if guards.power_of_two(y) else (y, x)
            out = self._apply(s, ("S",), (x, y), (k.state, v.state))
            guards.after_scale(out, k, v)
            return out
        if q.inv and f.key not in q.unit_of:
            return self._invalid(s, "F", (x, y), _INV_MSG)
        out = self._apply(s, ("F",), (x, y), (x.state, y.state, x.key == y.key))
        if out.v and q.inv:
            # Rule G's "*": v_i·(1/‖v‖) is a component of a unit vector, c = 1.
            st = out.state
            out.state = State(sympy.Integer(1), st.p, st.n, st.a, st.b, st.r)
        out.tight = out.v and x.tight and y.tight
        return out

    def _quotient(self, s: str, x: "Tracked", y: "Tracked") -> "Tracked":
        """Rule SD (÷2^k, exact), else G (relative operands: a quotient with c = 1*),
        else GL (a divisor bounded below by a passed check: a true magnitude bound)."""
        if x.inv or y.inv:
            return self._invalid(s, "G", (x, y), _INV_MSG)
        if guards.power_of_two(y):
            out = self._apply(s, ("SD",), (x, y), (x.state, y.state))
            guards.after_scale(out, x, y)
            return out
        out = self._apply(s, ("G",), (x, y), (x.state, y.state))
        if out.v:
            out.inv = True
            if x.rule == "J" and x.c == 1:
                out.unit_of = _norm_components(y)
            return out
        if x.v and y.v and y.floor is not None:
            fx = None if x.r else x.floor
            gl = self._apply(s, ("GL",), (x, y), (x.state, y.state, y.floor, fx))
            if gl.v:
                gl.premises = ((y, 1),) + (((x, 1),) if fx is not None else ())
                return gl
        if y.v and y.floor is None and x.v:
            out.why += (f"; or a divisor bounded below: reject |{y.label}| <= T (a "
                        "tolerance) before dividing (rule GL, docs/custom-predicates.md)")
        return out

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
    """The keys of v's components when m = sqrt(v_1·v_1 + ... + v_k·v_k), else empty."""
    if m.rule != "H" or not m.args:
        return frozenset()
    comps, stack = set(), [m.args[0]]
    while stack:
        t = stack.pop()
        if t.rule in ("B", "C") and len(t.args) == 2:
            stack.extend(t.args)
        elif t.rule == "F" and t.args[0].key == t.args[1].key:
            comps.add(t.args[0].key)
        else:
            return frozenset()
    return frozenset(comps)


def _simplify(st: State) -> State:
    """Sympy-valued fields simplified as before; rational ones (Fractions) are exact
    and canonical already, so the common case costs nothing."""
    exact = (Fraction, EpsFrac)  # canonical already: reduced fractions
    if all(isinstance(v, exact) for v in (st._c, st._p, st._a, st._b)):
        return st
    f = lambda e: e if isinstance(e, exact) else \
        sympy.nsimplify(e) if isinstance(e, sympy.Float) else sympy.radsimp(e)
    p = st._p if isinstance(st._p, Fraction) else sympy.nsimplify(st._p)
    return State(f(st._c), p, st.n, f(st._a), f(st._b), st.r)


_KEYS: dict[tuple, int] = {}


def _intern(structure: tuple) -> int:
    """A small integer per structure (a leaf's text, or an operation and its operands'
    keys): equal keys ⇔ equal texts, compared in O(1)."""
    return _KEYS.setdefault(structure, len(_KEYS))


def _text(root: "Tracked") -> str:
    """The canonical text of ``root``, post-order without recursion (no depth limit)."""
    memo: dict[int, str] = {}
    stack = [root]
    while stack:
        t = stack[-1]
        if id(t) in memo:
            stack.pop()
            continue
        if t._s is not None:
            memo[id(t)] = t._s
            stack.pop()
            continue
        pending = [a for a in t.args if id(a) not in memo]
        if pending:
            stack.extend(pending)
            continue
        stack.pop()
        memo[id(t)] = ops.BY_RULE[t.rule].s_form.format(*(memo[id(a)] for a in t.args))
    return memo[id(root)]


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


def exact_input(name: str, c=1, p=1, nonnegative: bool = False,
                tight: bool = False) -> Tracked:
    """An exact input of magnitude c·L^p (rule K generalised: e.g. the scale L itself);
    ``tight``: its value is exactly c·L^p (L^p itself), not only bounded by it."""
    st = State(sympy.sympify(c), sympy.sympify(p), nonnegative,
               sympy.Integer(0), sympy.Integer(0), True)
    out = Tracked(name, st, "K")
    out.tight = tight and nonnegative
    return out


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
    out = Tracked(s, rules.rule_J(value, use_exact), "J")
    out.tight = bool(value >= 0)  # |value| = c: a non-negative constant is its bound
    return out


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
