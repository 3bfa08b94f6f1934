"""Tolerance coefficients as data: a small bounded grammar read exactly, never evaluated
as Python.

Tolerance tables (``fperr verify --tolerances``, ``fperr intersect --tolerances``,
``predicates.tolerances(table=...)``, what ``fperr synthesize`` writes, users'
``FPERR_TOLERANCES``; docs/custom-predicates.md, docs/synthesized-tolerances.md) hold
coefficients such as ``"269/64"``, ``"9.5"``, ``"31085883*sqrt(3)/16384"``,
``"2*(7/2)^2"`` or ``"24*sqrt(eps)*L^2"``. The grammar::

    expr   := term (("+" | "-") term)*
    term   := unary (("*" | "/") unary)*
    unary  := ("+" | "-") unary | power
    power  := atom (("^" | "**") unary)?        exponent: a constant rational 0..64,
                                                  denominator 1, 2 or 4
    atom   := NUMBER | NAME | NAME "(" expr ("," expr)* ")" | "(" expr ")"

NUMBER is an integer or a decimal (``9.5``, ``1e-3``; read exactly); NAME is ``eps``,
``L``, a function (``sqrt``; ``min``/``max`` in declared facts) or a name the caller
allows. Everything is bounded (string length, tokens, nesting, literal digits,
exponents, the size of every intermediate value), so a table can neither run code nor
hang the run; every refusal is a :class:`CoefficientError` (a ValueError) naming the
problem. :func:`value` computes the exact :class:`Monomial` c·√m·ε^q·L^p without sympy;
:func:`to_sympy` builds the sympy expression from the parsed tree (the proofs' side),
never from text.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from fractions import Fraction

MAX_LENGTH = 1000        # characters of one coefficient string
MAX_TOKENS = 300
MAX_DEPTH = 40           # nesting of parentheses, unary signs and powers
MAX_DIGITS = 60          # digits of one numeric literal
MAX_DECIMAL_EXPONENT = 60
MAX_EXPONENT = 64        # of ^ / **
MAX_BITS = 4096          # numerator, denominator of any intermediate value
MAX_RADICAND_BITS = 512

FUNCTIONS = {"sqrt": 1, "min": None, "max": None, "Min": None, "Max": None}
BUILTIN_NAMES = ("eps", "L")

_TOKEN = re.compile(r"\s*(?:(?P<num>(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)"
                    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<op>\*\*|[-+*/^(),]))")


class CoefficientError(ValueError):
    """A coefficient string outside the grammar or its bounds (the message says which)."""


class UnlikeTerms(CoefficientError):
    """A sum such as 1 + √3 or ε + L: an expression, but not one :class:`Monomial`."""


class UnknownName(CoefficientError):
    """A name that is neither eps, L, a function nor one the caller allows."""

    def __init__(self, name: str):
        super().__init__(f"unknown name {name!r}")
        self.name = name


@dataclass(frozen=True, eq=False)
class Monomial:
    """The exact value c·√m·ε^q·L^p (c rational, m ≥ 1 an integer, q, p rational)."""

    c: Fraction
    m: int = 1
    q: Fraction = Fraction(0)
    p: Fraction = Fraction(0)

    @staticmethod
    def make(c, m: int = 1, q=Fraction(0), p=Fraction(0)) -> "Monomial":
        c, q, p = Fraction(c), Fraction(q), Fraction(p)
        if c == 0:
            return Monomial(Fraction(0))
        if m.bit_length() > MAX_RADICAND_BITS:
            raise CoefficientError("a square root's argument is too large")
        r = math.isqrt(m)
        if r * r == m:
            c, m = c * r, 1
        for v in (c.numerator, c.denominator):
            if v.bit_length() > MAX_BITS:
                raise CoefficientError(f"a value exceeds {MAX_BITS} bits")
        return Monomial(c, m, q, p)

    def _key(self):
        return (self.q, self.p, self.c > 0, self.c * self.c * self.m)

    def __eq__(self, o) -> bool:  # √m is not reduced to square-free: compare c²m
        o = _coerce(o)
        return NotImplemented if o is NotImplemented else self._key() == o._key()

    def __hash__(self) -> int:
        return hash(self._key())

    @property
    def is_constant(self) -> bool:
        return self.q == 0 and self.p == 0

    @property
    def is_rational(self) -> bool:
        return self.m == 1

    def __mul__(self, o) -> "Monomial":
        o = _coerce(o)
        if o is NotImplemented:
            return o
        g = math.gcd(self.m, o.m)  # √a·√b = g·√((a/g)(b/g))
        return Monomial.make(self.c * o.c * g, (self.m // g) * (o.m // g),
                             self.q + o.q, self.p + o.p)

    __rmul__ = __mul__

    def __truediv__(self, o) -> "Monomial":
        o = _coerce(o)
        if o is NotImplemented:
            return o
        if o.c == 0:
            raise CoefficientError("division by zero")
        inv = Monomial.make(1 / (o.c * o.m), o.m, -o.q, -o.p)  # 1/(c√m) = √m/(c·m)
        return self * inv

    def __rtruediv__(self, o) -> "Monomial":
        o = _coerce(o)
        return o if o is NotImplemented else o / self

    def __neg__(self) -> "Monomial":
        return Monomial(-self.c, self.m, self.q, self.p)

    def __add__(self, o) -> "Monomial":
        o = _coerce(o)
        if o is NotImplemented:
            return o
        if self.c == 0:
            return o
        if o.c == 0:
            return self
        r = math.isqrt(self.m * o.m)  # √b = (r/a)·√a when a·b is a square
        if (self.q, self.p) != (o.q, o.p) or r * r != self.m * o.m:
            raise UnlikeTerms("a sum of unlike terms (different radicals or powers "
                                   "of eps, L) is not a single coefficient")
        return Monomial.make(self.c + o.c * Fraction(r, self.m), self.m, self.q, self.p)

    def __sub__(self, o) -> "Monomial":
        o = _coerce(o)
        return o if o is NotImplemented else self + (-o)

    def sqrt(self) -> "Monomial":
        if self.c < 0:
            raise CoefficientError("square root of a negative number")
        if self.m != 1:
            raise CoefficientError("square root of an irrational number (a fourth root) "
                                   "is not supported")
        n, d = self.c.numerator, self.c.denominator  # √(n/d) = √(n·d)/d
        return Monomial.make(Fraction(1, d), n * d, self.q / 2, self.p / 2)

    def power(self, e: Fraction) -> "Monomial":
        k = e.denominator
        out = Monomial(Fraction(1))
        for _ in range(e.numerator):
            out = out * self
        while k > 1:
            out, k = out.sqrt(), k // 2
        return out

    def fraction(self) -> Fraction:
        """The exact rational value (a constant with no radical), else CoefficientError."""
        if not (self.is_constant and self.is_rational):
            raise CoefficientError(f"{self} is not a rational constant")
        return self.c

    def _sympy_(self):  # sympy's conversion hook: Monomials mix with the proofs' values
        return to_sympy(self)

    def __float__(self) -> float:
        return float(self.c) * math.sqrt(self.m)

    def __str__(self) -> str:
        parts = ([f"sqrt({self.m})"] if self.m != 1 else [])
        parts += [f"{s}^({e})" if e.denominator != 1 else f"{s}^{e}"
                  for s, e in (("eps", self.q), ("L", self.p)) if e]
        if self.c.numerator != 1 or not parts:
            parts.insert(0, str(self.c.numerator))
        text = "*".join(parts)
        return text if self.c.denominator == 1 else f"{text}/{self.c.denominator}"


def _coerce(o):
    """An int or Fraction as a Monomial; anything else NotImplemented."""
    if isinstance(o, Monomial):
        return o
    if isinstance(o, (int, Fraction)) and not isinstance(o, bool):
        return Monomial.make(o)
    return NotImplemented


def _tokens(text: str) -> list[tuple[str, str]]:
    if len(text) > MAX_LENGTH:
        raise CoefficientError(f"longer than {MAX_LENGTH} characters")
    out, pos, text = [], 0, text.rstrip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None or m.end() == pos:
            bad = text[pos:].lstrip()[:1]
            raise CoefficientError(f"unexpected character {bad!r} at position "
                                   f"{text.index(bad, pos) + 1} (a coefficient holds numbers, "
                                   "eps, L, sqrt, + - * / ^ and parentheses)")
        kind = m.lastgroup
        tok = m.group(kind)
        if kind == "num" and len(re.sub(r"[eE].*", "", tok)) > MAX_DIGITS:
            raise CoefficientError(f"a number with more than {MAX_DIGITS} digits")
        out.append((kind, tok))
        pos = m.end()
        if len(out) > MAX_TOKENS:
            raise CoefficientError(f"more than {MAX_TOKENS} tokens")
    return out


class _Parser:
    """Recursive descent over the tokens; the tree is nested tuples (see :func:`parse`)."""

    def __init__(self, tokens, names):
        self.toks, self.i, self.names, self.depth = tokens, 0, names, 0

    def peek(self):
        return self.toks[self.i] if self.i < len(self.toks) else (None, None)

    def take(self, op: str | None = None):
        kind, tok = self.peek()
        if kind is None:
            raise CoefficientError("unexpected end" + (f" (expected {op!r})" if op else ""))
        if op is not None and tok != op:
            raise CoefficientError(f"expected {op!r}, found {tok!r}")
        self.i += 1
        return kind, tok

    def nest(self):
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise CoefficientError(f"nested deeper than {MAX_DEPTH}")

    def expr(self):
        node = self.term()
        while self.peek()[1] in ("+", "-"):
            op = "add" if self.take()[1] == "+" else "sub"
            node = (op, node, self.term())
        return node

    def term(self):
        node = self.unary()
        while self.peek()[1] in ("*", "/"):
            op = "mul" if self.take()[1] == "*" else "div"
            node = (op, node, self.unary())
        return node

    def unary(self):
        if self.peek()[1] in ("+", "-"):
            self.nest()
            sign = self.take()[1]
            node = self.unary()
            self.depth -= 1
            return ("neg", node) if sign == "-" else node
        return self.power()

    def power(self):
        base = self.atom()
        if self.peek()[1] not in ("^", "**"):
            return base
        self.take()
        self.nest()
        exp = self.unary()
        self.depth -= 1
        e = _constant_exponent(exp)
        return ("pow", base, e)

    def atom(self):
        kind, tok = self.take()
        if kind == "num":
            return ("num", _literal(tok))
        if tok == "(":
            self.nest()
            node = self.expr()
            self.take(")")
            self.depth -= 1
            return node
        if kind == "name":
            if tok in FUNCTIONS:
                return self.call(tok)
            if tok in BUILTIN_NAMES or tok in self.names:
                return ("name", tok)
            raise UnknownName(tok)
        raise CoefficientError(f"unexpected {tok!r}")

    def call(self, func: str):
        self.take("(")
        self.nest()
        args = [self.expr()]
        while self.peek()[1] == ",":
            self.take()
            args.append(self.expr())
        self.take(")")
        self.depth -= 1
        if FUNCTIONS[func] is not None and len(args) != FUNCTIONS[func]:
            raise CoefficientError(f"{func} takes {FUNCTIONS[func]} argument(s)")
        return ("call", func, tuple(args))


def _literal(tok: str) -> Fraction:
    mant, _, exp = tok.lower().partition("e")
    if exp and abs(int(exp)) > MAX_DECIMAL_EXPONENT:
        raise CoefficientError(f"the decimal exponent of {tok} exceeds {MAX_DECIMAL_EXPONENT}")
    return Fraction(mant) * Fraction(10) ** int(exp or 0)


def _constant_exponent(node) -> Fraction:
    e = value(node)
    if not (e.is_constant and e.is_rational):
        raise CoefficientError("an exponent must be a rational constant")
    e = e.c
    if not (0 <= e <= MAX_EXPONENT and e.denominator in (1, 2, 4)):
        raise CoefficientError(f"exponent {e} outside 0..{MAX_EXPONENT} with denominator "
                               "1, 2 or 4")
    return e


def parse(text: str, names=()) -> tuple:
    """The tree of ``text``: ("num", Fraction), ("name", str), ("neg", x), ("add"|"sub"|
    "mul"|"div", x, y), ("pow", x, Fraction), ("call", func, args). ``names``: further
    symbol names allowed (declared facts' ``tau_lo`` ...)."""
    if not isinstance(text, str):
        raise CoefficientError(f"expected a string, got {type(text).__name__}")
    toks = _tokens(text)
    if not toks:
        raise CoefficientError("empty expression")
    p = _Parser(toks, frozenset(names))
    node = p.expr()
    if p.i != len(toks):
        raise CoefficientError(f"unexpected {toks[p.i][1]!r} at token {p.i + 1}")
    return node


_BUILTIN = {"eps": Monomial(Fraction(1), 1, Fraction(1)),
            "L": Monomial(Fraction(1), 1, Fraction(0), Fraction(1))}


def value(node) -> Monomial:
    """The exact value of a tree from :func:`parse` (no other names, no min/max)."""
    op = node[0]
    if op == "num":
        return Monomial.make(node[1])
    if op == "name":
        if node[1] not in _BUILTIN:
            raise CoefficientError(f"{node[1]!r} has no numeric value here")
        return _BUILTIN[node[1]]
    if op == "neg":
        return -value(node[1])
    if op == "pow":
        return value(node[1]).power(node[2])
    if op == "call":
        if node[1] != "sqrt":
            raise CoefficientError(f"{node[1]} is not allowed in a coefficient")
        return value(node[2][0]).sqrt()
    a, b = value(node[1]), value(node[2])
    return {"add": a.__add__, "sub": a.__sub__, "mul": a.__mul__,
            "div": a.__truediv__}[op](b)


def constant(v, where: str = "") -> Monomial:
    """A positive constant coefficient from an int, a decimal float (read as the decimal
    it prints as), a Fraction, a string of the grammar or a :class:`Monomial`; the
    CoefficientError names ``where`` (file, key)."""
    prefix = f"{where}: " if where else ""
    try:
        if isinstance(v, bool):
            raise CoefficientError("a boolean is not a coefficient")
        if isinstance(v, Monomial):
            x = v
        elif isinstance(v, (int, Fraction)):
            x = Monomial.make(Fraction(v))
        elif isinstance(v, float):
            if not math.isfinite(v):
                raise CoefficientError(f"coefficient must be finite, got {v!r}")
            x = Monomial.make(Fraction(repr(v)))  # the decimal the user wrote, exactly
        elif isinstance(v, str):
            x = value(parse(v))
        else:
            raise CoefficientError(f"expected a number or a string, got {v!r}")
        if not x.is_constant or x.c <= 0:
            raise CoefficientError(f"coefficient must be a positive constant, got {v!r}")
        return x
    except CoefficientError as e:
        raise CoefficientError(f"{prefix}{e}") from None


def to_sympy(x, symbols: dict | None = None):
    """The sympy value of a :class:`Monomial` or a tree from :func:`parse` (names from
    ``symbols``, and ε, L of :mod:`fperr.symbols`). Sub-trees without names go through
    :func:`value`, so their size stays bounded."""
    import sympy

    from fperr.symbols import L, eps

    if isinstance(x, Monomial):
        return (sympy.Rational(x.c.numerator, x.c.denominator) * sympy.sqrt(x.m)
                * eps ** sympy.Rational(x.q.numerator, x.q.denominator)
                * L ** sympy.Rational(x.p.numerator, x.p.denominator))
    if not _has_names(x):
        try:
            return to_sympy(value(x))
        except UnlikeTerms:
            pass  # built term by term below, each term through value()
    symbols = dict({"eps": eps, "L": L}, **(symbols or {}))
    op, args = x[0], x[1:]
    if op == "name":
        return symbols[x[1]]
    if op == "neg":
        return -to_sympy(x[1], symbols)
    if op == "pow":
        return to_sympy(x[1], symbols) ** sympy.Rational(x[2].numerator, x[2].denominator)
    if op == "call":
        f = {"sqrt": sympy.sqrt, "min": sympy.Min, "Min": sympy.Min, "max": sympy.Max,
             "Max": sympy.Max}[x[1]]
        return f(*(to_sympy(a, symbols) for a in x[2]))
    a, b = (to_sympy(y, symbols) for y in args)
    if op == "add":
        return a + b
    if op == "sub":
        return a - b
    return a * b if op == "mul" else a / b


def _has_names(node) -> bool:
    """Whether a tree holds a name or a min/max (what :func:`value` may not take)."""
    if node[0] == "name":
        return True
    if node[0] == "call":
        return node[1] != "sqrt" or any(_has_names(a) for a in node[2])
    return any(isinstance(a, tuple) and _has_names(a) for a in node[1:])
