"""The predicates' one source, recorded as straight-line scalar code.

A predicate (:mod:`predicates.d2`, :mod:`predicates.d3`) is written once against a context
(docs/design.md, "One source, several number systems"). :class:`TraceContext` is one more
context: its numbers are symbols, and every operation the source performs — in the order
Python evaluates it, with the operands it names — appends one statement
``tK = a ∘ b`` to a program. ``ctx.reject(cond)`` becomes "this lane is rejected when
``cond``" (``continue`` in the compiled loop, like the numpy context's lane mask: a
rejected lane's values are never used), ``ctx.hit(weights)`` the lane's output.

The program is therefore the predicate's operations, one rounding each, in exactly the
numpy batch path's order: nothing is reassociated, fused or simplified here, and the
compiler is told not to either (:mod:`predicates.compiled.build`). Python number literals
(``1 / m``) become constants of the working dtype, as numpy's weak scalars do (NEP 50).
"""
from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["Program", "trace"]


@dataclass
class Program:
    """A predicate as straight-line statements over the inputs ``x{k}`` (point-major:
    point p, axis a is ``x{p*dim + a}``) and the tolerances ``tol[{k}]``.

    ``lines``: statements (``tK = ...``, ``reject cond``) in source order; ``tolerances``:
    the tolerance names read, in the order of ``tol``'s entries; ``weights``: the
    symbols of the weights of a hit."""

    name: str
    dim: int
    n_points: int
    lines: list = field(default_factory=list)
    tolerances: list = field(default_factory=list)
    weights: tuple = ()
    temps: int = 0


class Sym:
    """A number (or a condition) of the traced program: the name of its statement."""

    __slots__ = ("prog", "ref")

    def __init__(self, prog: Program, ref: str):
        self.prog, self.ref = prog, ref

    def _emit(self, expr: str) -> "Sym":
        ref = f"t{self.prog.temps}"
        self.prog.temps += 1
        self.prog.lines.append(("let", ref, expr))
        return Sym(self.prog, ref)

    def _arg(self, other) -> str:
        if isinstance(other, Sym):
            return other.ref
        if isinstance(other, bool) or not isinstance(other, (int, float)):
            raise TypeError(f"cannot compile an operation with {type(other).__name__} "
                            f"{other!r} (numbers of the predicate only)")
        if float(other) != other or not float(other).is_integer() or abs(other) > 2 ** 24:
            raise TypeError(f"literal {other!r}: only small integers are exact in float32")
        return f"T({float(other)!r})"  # the working dtype's constant (numpy's weak scalar)

    def _bin(self, op: str, other, swap: bool = False) -> "Sym":
        a, b = self.ref, self._arg(other)
        if swap:
            a, b = b, a
        return self._emit(f"{a} {op} {b}")

    def __add__(self, o): return self._bin("+", o)
    def __radd__(self, o): return self._bin("+", o, True)
    def __sub__(self, o): return self._bin("-", o)
    def __rsub__(self, o): return self._bin("-", o, True)
    def __mul__(self, o): return self._bin("*", o)
    def __rmul__(self, o): return self._bin("*", o, True)
    def __truediv__(self, o): return self._bin("/", o)
    def __rtruediv__(self, o): return self._bin("/", o, True)
    def __lt__(self, o): return self._bin("<", o)
    def __le__(self, o): return self._bin("<=", o)
    def __gt__(self, o): return self._bin(">", o)
    def __ge__(self, o): return self._bin(">=", o)
    def __eq__(self, o): return self._bin("==", o)
    def __ne__(self, o): return self._bin("!=", o)
    def __neg__(self): return self._emit(f"-{self.ref}")
    def __abs__(self): return self._emit(f"abs({self.ref})")
    __hash__ = None

    def __bool__(self):
        raise TypeError("a predicate decides through ctx.reject/ctx.any, never through "
                        "`if` on a number: it cannot be compiled (docs/design.md)")


class _Tol:
    """The tolerances as symbols ``tol[k]``, numbered in order of first use."""

    def __init__(self, prog: Program):
        self._prog, self._syms = prog, {}

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        if name not in self._syms:
            self._syms[name] = Sym(self._prog, f"tol[{len(self._prog.tolerances)}]")
            self._prog.tolerances.append(name)
        return self._syms[name]


class TraceContext:
    """The context interface of :mod:`fperr.contexts`, recording (module docstring)."""

    vectorised = False

    def __init__(self, prog: Program):
        self.prog = prog
        self.done = False

    def _sym(self, expr: str) -> Sym:
        return Sym(self.prog, "")._emit(expr)

    def name(self, label, x):
        return x

    def sqrt(self, x):
        return self._sym(f"math.sqrt({x.ref})")

    def reject(self, cond, line=None) -> bool:
        self.prog.lines.append(("reject", cond.ref, line))
        return False  # trace on: the rest of the source is what an accepted lane runs

    def any(self, *conds):
        return self._sym(" | ".join(c.ref for c in conds))

    def same_sign(self, x, y):
        return (x > 0) == (y > 0)  # as FloatContext / NumpyContext: signs against 0

    def differ_sign(self, x, y):
        return (x > 0) != (y > 0)

    def hit(self, weights):
        self.prog.weights = tuple(weights)
        self.done = True
        return True, weights

    def miss(self):  # never reached: reject() never stops the trace
        raise AssertionError("traced predicate returned a miss")


def trace(pred) -> Program:
    """The :class:`Program` of a :class:`predicates.core.Predicate` (its ``fn``)."""
    n = len(pred.points)
    prog = Program(pred.name, pred.dim, n)
    pts = [tuple(Sym(prog, f"x{p * pred.dim + a}") for a in range(pred.dim))
           for p in range(n)]
    ctx = TraceContext(prog)
    pred.fn(ctx, *pts, _Tol(prog))
    if not ctx.done or len(prog.weights) != len(pred.weight_names):
        raise ValueError(f"{pred.name}: the traced source did not end in ctx.hit with "
                         f"{len(pred.weight_names)} weights")
    return prog
