"""One predicate source, four number systems.

A predicate is a plain function ``f(ctx, A, B, ..., tol)`` written against a
:class:`fperr.Context`. :class:`Predicate` wraps it into the public callable
``f(A, B, ..., tol, ctx=None)`` that picks the number system from the inputs
(Tracked → instrumented, numpy arrays → batch, mpmath → mpmath, else Python floats),
validates and converts the points, and runs the body in the context's session.
"""
from __future__ import annotations

import functools
import inspect
from dataclasses import dataclass

import numpy as np

import fperr

from . import premise
from .tolerances import Tolerances, UnknownTolerance, check_dim, tracked_tolerances


@dataclass(frozen=True)
class Instrumented:
    """Result of an instrumented run: named quantities, recorded checks, weights."""

    algorithm: str
    dim: int
    quantities: dict
    checks: list
    weights: tuple


class Predicate:
    """A predicate of the paper, callable in every number system (see module doc)."""

    def __init__(self, fn, dim: int, points: str, weights: tuple, algorithm: int,
                 section: str = "", sim: str | None = None, bracket: str | None = None,
                 reach: tuple[str, float] | None = None):
        self.fn = fn
        self.dim = dim
        self.points = tuple(points)
        self.weight_names = tuple(weights)
        self.algorithm = algorithm
        self.name = fn.__name__
        # the catalogue entry (predicates.catalogue derives kinds, sub-pairs, reach from it)
        self.section = section
        self.title = "-".join(w.capitalize() for w in self.name.split("_"))
        sim = points[: len(points) // 2] if sim is None else sim
        if not points.startswith(sim) or not 0 < len(sim) < len(points):
            raise ValueError(f"{self.name}: the simulation points {sim!r} must be a proper "
                             f"prefix of the points {points!r}")
        self.sim, self.cut = tuple(sim), tuple(points[len(sim):])
        self.bracket = bracket
        self.reach = reach
        functools.update_wrapper(self, fn)
        self.__signature__ = self._call_signature(fn)
        self.__doc__ = (fn.__doc__ or "").rstrip() + self._call_doc()

    def _call_signature(self, fn) -> inspect.Signature:
        """The signature a user calls, derived from the source: its points and ``tol``
        (the source's parameters without ``ctx``), then the keyword ``ctx``."""
        params = list(inspect.signature(fn).parameters.values())[1:]
        point = "tuple[float, ...] | numpy.ndarray"
        out = [q.replace(kind=inspect.Parameter.POSITIONAL_ONLY, annotation=point)
               for q in params[:-1]]
        out.append(params[-1].replace(kind=inspect.Parameter.POSITIONAL_ONLY,
                                      annotation="predicates.Tolerances"))
        out.append(inspect.Parameter("ctx", inspect.Parameter.KEYWORD_ONLY, default=None,
                                     annotation="fperr.Context | None"))
        return inspect.Signature(out, return_annotation="tuple[bool | numpy.ndarray, "
                                                        "tuple | numpy.ndarray]")

    def _call_doc(self) -> str:
        k, pts = len(self.weight_names), ", ".join(self.points)
        w = ", ".join(self.weight_names) or "none"
        return (f"\n\n    Call: ``{self.name}({pts}, tol, *, ctx=None)``, each point a "
                f"tuple of {self.dim} coordinates or an array of shape (..., {self.dim}) "
                "(numpy's gufunc convention: leading axes broadcast). Returns ``(hit, "
                f"weights)``: a bool and a tuple of {k} numbers ({w}), or arrays of shapes "
                f"(...) and (..., {k}). ``tol``: ``predicates.tolerances({self.dim}, L_a, "
                "L_b, dtype)``; ``ctx``: a number system (fperr.context), by default "
                "the inputs' own.")

    def __repr__(self):
        return f"<predicate {self.dim}D {self.name}({', '.join(self.points)}, tol)>"

    def __call__(self, *args, ctx: fperr.Context | None = None):
        if len(args) != len(self.points) + 1:
            raise TypeError(f"{self.name} takes points {', '.join(self.points)} and tol "
                            f"({len(self.points) + 1} arguments), got {len(args)}")
        *pts, tol = args
        if not isinstance(tol, Tolerances) or tol.dim != self.dim:
            raise TypeError(f"{self.name}: tol must be {self.dim}D Tolerances "
                            "(predicates.tolerances(...))")
        ctx = ctx if ctx is not None else fperr.context_for(*pts)
        if ctx.vectorised:
            return self._batch(pts, tol, ctx)
        self._check_scalar_points(pts)
        run = ctx.fresh(len(self.weight_names))
        tol_values = self._tolerances_for(tol, run)
        if ctx.bits is not None:  # a rounding number system: rule K's premise
            premise.check_scalar(self, pts, tol.L)
        with run.session():
            coords = [run.coords(p, lbl) for p, lbl in zip(pts, self.points)]
            return self.fn(run, *coords, tol_values)

    #: Lanes per block in batch mode: temporaries of one block stay in cache, and a
    #: block whose lanes are all rejected stops early.
    BLOCK = 1 << 15

    def _batch(self, pts, tol, ctx):
        """numpy's gufunc convention: every point array has shape (..., dim); the leading
        shapes broadcast to a batch shape B; ``hit`` has shape B (0-d for single points)
        and the weights B + (k,)."""
        arrs, batch = self._batch_points(pts, ctx)
        hit, weights = self._batch_flat(arrs, tol, ctx)
        k = len(self.weight_names)
        return hit.reshape(batch), weights.reshape(batch + (k,))

    def _batch_flat(self, arrs, tol, ctx):
        n = arrs[0].shape[0]
        k = len(self.weight_names)
        hit = np.zeros(n, dtype=bool)
        weights = np.zeros((n, k), dtype=ctx.dtype)
        tol_values = None
        for start in range(0, n, self.BLOCK):
            stop = min(n, start + self.BLOCK)
            blocks = [a[start:stop] for a in arrs]
            for b, lbl in zip(blocks, self.points):  # a cache-resident check per block
                if not np.isfinite(b).all():
                    raise ValueError(f"{self.name}: point {lbl} has non-finite coordinates")
            premise.check_batch(self, blocks, tol.L)  # rule K's premise, one reduction
            run = ctx.fresh(k, stop - start)
            run.out = weights[start:stop]  # hit() writes the weights in place
            if tol_values is None:
                tol_values = self._tolerances_for(tol, run)
            with run.session():
                # strided column views: no transposed copy of the inputs
                coords = [tuple(b[:, j] for j in range(self.dim)) for b in blocks]
                h, _ = self.fn(run, *coords, tol_values)
            hit[start:stop] = h
        return hit, weights

    # -- input handling ------------------------------------------------------------
    def _check_scalar_points(self, pts):
        for p, lbl in zip(pts, self.points):
            if not isinstance(p, (tuple, list)) and np.ndim(p) != 1 or len(p) != self.dim:
                raise ValueError(f"{self.name}: point {lbl} must have {self.dim} "
                                 f"coordinates, got {p!r}")

    def _batch_points(self, pts, ctx):
        """The points as (n, dim) arrays over the broadcast batch shape, and that shape."""
        arrs = [np.asarray(p) for p in pts]
        for a, lbl in zip(arrs, self.points):
            if a.ndim < 1 or a.shape[-1] != self.dim:
                raise ValueError(f"{self.name}: {lbl} must have shape (..., {self.dim}) "
                                 f"(e.g. (n, {self.dim}) or ({self.dim},)), got {a.shape}")
            if a.dtype != ctx.dtype:
                raise TypeError(f"{self.name}: {lbl} has dtype {a.dtype}; all points must "
                                f"be {ctx.dtype} (convert explicitly: rounding changes the "
                                "geometry)")
        try:
            batch = np.broadcast_shapes(*[a.shape[:-1] for a in arrs])
        except ValueError:
            raise ValueError(f"{self.name}: the points' batch shapes "
                             f"{', '.join(str(a.shape[:-1]) for a in arrs)} do not "
                             "broadcast") from None
        flat = [np.broadcast_to(a, batch + (self.dim,)).reshape(-1, self.dim) for a in arrs]
        return flat, batch

    def _tolerances_for(self, tol: Tolerances, run):
        """``tol`` converted to ``run``'s number type (cached on ``tol`` per type)."""
        key = (type(run), run.format)
        cache = tol.__dict__.setdefault("_converted", {})
        if key not in cache:
            cache[key] = self._convert_tolerances(tol, run)
        return cache[key]

    def _convert_tolerances(self, tol: Tolerances, run):
        """The values of ``tol`` as numbers of ``run`` (exact: a format at least as
        precise as the one they were computed for holds them). A Tracked/numeric mix
        is refused by ``run.convert``."""
        src = tol.ctx
        if src.bits is not None and run.bits is not None and src.bits > run.bits:
            raise ValueError(f"{self.name}: tolerances were computed for ε = {float(tol.eps)!r}"
                             f" but the arithmetic has ε = {float(run.eps)!r}; compute them "
                             "for this format (predicates.tolerances(..., dtype=...))")
        with run.session():
            vals = {k: run.convert(v) for k, v in tol.values.items()}
        return Tolerances(tol.dim, tol.L, tol.eps, run, vals)

    # -- instrumented run --------------------------------------------------------------
    def instrumented(self, table: dict | None = None) -> Instrumented:
        """Run the predicate on Tracked coordinates (rule K) and tracked tolerances
        (``table``: name → ToleranceSpec overriding Figure 1/5, as the proofs try)."""
        frozen = None if table is None else tuple(sorted(table.items()))
        return _instrumented(self, frozen)


@functools.lru_cache(maxsize=128)
def _instrumented(pred: Predicate, frozen_table) -> Instrumented:
    check_dim(pred.dim, frozen_table)
    axes = "xyz"[: pred.dim] if pred.dim <= 3 else [f"x{i}" for i in range(pred.dim)]
    pts = [tuple(fperr.coord(f"{p}.{a}") for a in axes) for p in pred.points]
    run = fperr.context("tracked").fresh(len(pred.weight_names))
    tol = tracked_tolerances(pred.dim, None if frozen_table is None else dict(frozen_table))
    coords = [run.coords(p, lbl) for p, lbl in zip(pts, pred.points)]
    try:
        pred.fn(run, *coords, tol)
    except UnknownTolerance as e:
        figure = "Figure 1" if pred.dim == 2 else "Figure 5"
        source = f"the paper's {figure}" if frozen_table is None else "the table given"
        raise ValueError(
            f"{pred.name}: tolerance {e.name!r} is not in {source} (it has: "
            f"{', '.join(e.known)}); pass the table of your tolerances, "
            f"{pred.name}.instrumented({{'{e.name}': ToleranceSpec(...), ...}}), or declare "
            "it in FPERR_TOLERANCES and use fperr verify --predicates "
            "(docs/custom-predicates.md)") from None
    for name, w in zip(pred.weight_names, run.weights):
        w.name = name
    return Instrumented(pred.name, pred.dim, dict(run.quantities), list(run.checks),
                        run.weights)


def predicate(dim: int, points: str, weights: tuple = (), algorithm: int = 0, *,
              section: str = "", sim: str | None = None, bracket: str | None = None,
              reach: tuple[str, float] | None = None):
    """Decorator: register ``fn(ctx, *points, tol)`` as a :class:`Predicate`.

    The one declaration of what a predicate is: its dimension, its points (the
    simulation primitive's first: ``sim``, default the first half; the cutting
    primitive's after), its weights, the paper's algorithm and ``section``, the tolerance
    whose bracket its inside-test uses (``bracket``; None for sign tests only) and its
    broad-phase ``reach`` ``(tolerance, factor)``: the pairs it can register are within
    factor·T of each other. :mod:`predicates.catalogue` derives everything else."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3 (the paper's registrations), got {dim!r}")

    def wrap(fn):
        return Predicate(fn, dim, points, weights, algorithm, section=section, sim=sim,
                         bracket=bracket, reach=reach)
    return wrap
