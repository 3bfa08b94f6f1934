"""The smallest tolerance coefficients the proofs accept (``fperr synthesize``).

The paper's Figures 1 and 5 are hand-picked. Correctness rests only on the constraint
system ``fperr verify`` decides (:mod:`proofs.verify`: brackets and setup of section 3,
4.1/5.1, the declared geometric facts, the windows and sign tests generated from the
instrumented predicates, section 5.4.4's argument), so the smallest coefficients it
accepts can be computed: every coefficient is bisected against the real decision
procedure, with ε ∈ (0, 1e-5] decided exactly as by ``fperr verify``.

Order (justified in docs/synthesized-tolerances.md): the declared facts make the
tolerances a dependency chain — an area/volume tolerance T bounds a length tolerance
from below (κ+ ≤ 2τ−², λ+ ≤ 16(τ−² − γ+²)², μ+ ≤ 4γ−²·min(γ−, δ−), ...), and τ+, σ̂+
bound σ− (τ+ < (√3/2)σ−, σ̂+ ≤ σ−). Lowering a tolerance never hurts the ones below
it, so the chain is minimised bottom-up — area/volume tolerances, then γ, δ, then
σ̂, τ, then σ — and within a tolerance T−, then T, then T+ (lowering T− only narrows
no window; T and T+ then sit as low as their windows allow). σ, the largest
tolerance and the one that decides which pairs collapse, is thus minimised given
minimal tolerances below it. Finally every T+ that a fact the paper prints as an
equality fixes (κ+ = 2τ−², λ+ = 16(τ−² − γ+²)², ...) is set to that value, as in the
paper (it only widens that T's upper window), unless that fails to verify.

Admissible values: T− and T+ are any positive rationals (bisected to 1 %); T must be a
dyadic a·2^b whose k-th power (k = denominator of its ε exponent) fits 17 bits (the
smallest format, mp17), because the code computes T = root_k(C^k·ε^(qk))·L^p with an
exact constant C^k (:func:`predicates.tolerances.tolerance_values`). That grid is about
6 % wide for the 3D length tolerances (k = 4, a ≤ 19), so there T is minimal on the grid.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import sympy

import predicates
from fperr import round_fraction
from fperr.symbols import L, eps
from predicates.registration.io.write import write_text_atomic

from . import tables
from .constraints import GEOMETRIC
from .decide import decide as _decide
from .tables import TABLES
from .verify import constraints, decide_constraint, instrument, verify

#: Bottom-up order of the dependency chain of the declared facts (module docstring).
ORDER = {2: ("kappa", "sigma_hat", "tau", "sigma"),
         3: ("lam", "phi", "nu", "zeta", "mu", "xi", "rho", "gamma", "delta",
             "sigma_hat", "tau", "sigma")}
FIELDS = ("lo", "mid", "hi")
TOLERANCE = Fraction(1, 100)   # bisection stops within 1 % of the boundary
MID_BITS = 17                  # C^k must be exact in the smallest format (mp17)


def _odd_part(x: Fraction) -> int:
    n = x.numerator
    while n % 2 == 0:
        n //= 2
    return n


def admissible_mid(c: Fraction, k: int, up: bool = True) -> Fraction:
    """The nearest value ≥ c (``up``) or ≤ c (c > 0) of the grid a·2^j, a odd with
    a^k < 2^17: T's constant C^k is then exact in every format (mp17 included)."""
    amax = int(round((2 ** MID_BITS) ** (1 / k)))
    while amax ** k >= 2 ** MID_BITS:
        amax -= 1
    nb = amax.bit_length()
    mode = "up" if up else "down"
    cands = [round_fraction(Fraction(c), b, mode) for b in (nb, nb - 1) if b >= 1]
    ok = [x for x in cands if _odd_part(x) <= amax]
    return min(ok) if up else max(ok)


def is_admissible_mid(c: Fraction, k: int) -> bool:
    return admissible_mid(c, k) == c


class PaperSystem:
    """The constraint system ``fperr verify`` decides for the paper's predicates of one
    dimension. A user's declaration (:class:`proofs.user_predicates.PredicateTolerances`)
    has the same attributes and methods, and is synthesized the same way."""

    label = "paper"

    def __init__(self, dim: int):
        self.dim, self.base, self.order = dim, TABLES[dim], ORDER[dim]
        self.facts = [f for (d, _), fs in GEOMETRIC.items() if d == dim for f in fs]

    def table(self, coeffs: dict) -> dict:
        """The table with ``coeffs`` ({name: {lo|mid|hi: value}}) applied."""
        return tables.table(self.dim, {self.dim: coeffs})

    def runs(self, tab: dict) -> dict:
        return {p.name: instrument(p, tab) for p in predicates.ALL[self.dim]}

    def constraints(self, coeffs: dict, runs: dict) -> list:
        return constraints(self.dim, {self.dim: coeffs}, runs)

    def verify(self, coeffs: dict):
        return verify(self.dim, {self.dim: coeffs})


@dataclass
class Synthesis:
    """A synthesized table: coefficients (name → {lo, mid, hi} as exact sympy numbers),
    per-coefficient probe counts, the final verification, timings."""

    dim: int
    coefficients: dict
    probes: int = 0
    seconds: float = 0.0
    equalities: list = field(default_factory=list)   # T+ set from a fact
    report: object = None
    base: dict | None = None   # the table started from (None: the paper's)
    label: str = "paper"

    def overrides(self) -> dict:
        return {self.dim: {n: dict(f) for n, f in self.coefficients.items()}}

    def ratios(self) -> dict:
        """name → (lo, mid, hi) ratios synthesized / paper (or the table started from)."""
        out = {}
        for n, f in self.coefficients.items():
            spec = (self.base or TABLES[self.dim])[n]
            out[n] = tuple(float(f[k] / getattr(spec, k)) for k in FIELDS)
        return out


class _Probe:
    """Feasibility of a coefficient table: every constraint holds for every ε ≤ 1e-5
    (the real decision procedure, memoised per inequality: a probe re-decides only the
    inequalities its change touches)."""

    def __init__(self, dim: int, system=None):
        self.dim, self.memo, self.count, self.runs = dim, {}, 0, {}
        self.system = system or PaperSystem(dim)

    def _runs(self, coeffs: dict) -> dict:
        """Instrumented runs depend only on the T coefficients (the code computes T
        alone): cached per tuple of ``mid``s, not per table."""
        key = tuple((n, coeffs[n]["mid"]) for n in sorted(coeffs))
        if key not in self.runs:
            self.runs[key] = self.system.runs(self.system.table({n: {"mid": m}
                                                                for n, m in key}))
        return self.runs[key]

    def _decide(self, lhs, rhs, strict=True):
        key = (lhs, rhs, strict)
        if key not in self.memo:
            self.memo[key] = _decide(lhs, rhs, strict)
        return self.memo[key]

    def failing(self, coeffs: dict) -> list[str]:
        self.count += 1
        cs = self.system.constraints(coeffs, self._runs(coeffs))
        bad = []
        for c in cs:
            try:
                ok = decide_constraint(c, decide=self._decide).holds
            except (TypeError, ValueError, ArithmeticError):
                ok = False  # e.g. √(σ−² − τ+²) of a negative number: not a valid table
            if not ok:
                bad.append(c.id)
                break  # one failure decides the probe
        return bad

    def __call__(self, coeffs: dict) -> bool:
        return not self.failing(coeffs)


def _frac(x) -> Fraction:
    x = sympy.nsimplify(x)
    if x.is_Rational:
        return Fraction(int(x.p), int(x.q))
    return Fraction(str(sympy.Rational(sympy.N(x, 30))))


def _with(coeffs, name, f, value):
    out = {n: dict(v) for n, v in coeffs.items()}
    out[name][f] = sympy.Rational(value.numerator, value.denominator)
    return out


def _start(probe: _Probe, coeffs: dict, name: str, f: str):
    """(coeffs, rational current value); an irrational T+ (ζ+ = 12√3·1521/16) is first
    replaced by a rational just below it (a fact may hold it with equality), if that
    verifies (else None)."""
    x = coeffs[name][f]
    if x.is_Rational:
        return coeffs, _frac(x)
    up = Fraction(str(sympy.Rational(sympy.N(x, 40)))) * (1 - Fraction(1, 10**30))
    trial = _with(coeffs, name, f, up)
    return (trial, up) if probe(trial) else (coeffs, None)


def _lower(probe: _Probe, coeffs: dict, name: str, f: str) -> dict:
    """Bisect ``coeffs[name][f]`` down to the smallest feasible value (to within 1 %, or
    on the admissible grid for T); a T− still feasible at 2^-12 of its value has no
    lower bound in the system and is left there (it is raised again afterwards)."""
    k = int(probe.system.base[name].q.q)
    coeffs, good = _start(probe, coeffs, name, f)
    if good is None:
        return coeffs
    snap = (lambda x: admissible_mid(x, k)) if f == "mid" else (lambda x: x)
    floor, bad = good / 2**12, None
    x = snap(good / 2)  # bracket the boundary by halving first
    while x < good and x >= floor:
        if not probe(_with(coeffs, name, f, x)):
            bad = x
            break
        good, x = x, snap(x / 2)
    if bad is None:
        return _with(coeffs, name, f, good)
    while good - bad > TOLERANCE * good:
        x = snap((good + bad) / 2)
        if x >= good or x <= bad:
            break
        if probe(_with(coeffs, name, f, x)):
            good = x
        else:
            bad = x
    return _with(coeffs, name, f, good)


def _raise_lo(probe: _Probe, coeffs: dict, name: str) -> dict:
    """Bisect T− up towards T (to within 1 %): the largest T− keeps the guarantee
    'inside with T− ⇒ registered' as strong as the windows allow."""
    good, bad = _frac(coeffs[name]["lo"]), _frac(coeffs[name]["mid"])
    while bad - good > TOLERANCE * good:
        x = (good + bad) / 2
        if probe(_with(coeffs, name, "lo", x)):
            good = x
        else:
            bad = x
    return _with(coeffs, name, "lo", good)


def _fact_equalities(dim: int, coeffs: dict, system=None) -> dict[str, sympy.Expr]:
    """T+ coefficients fixed by facts the paper (or a user) prints as equalities."""
    system = system or PaperSystem(dim)
    v = tables.Values(system.table(coeffs))
    out = {}
    for f in system.facts:
        if not f.equality:
            continue
        lhs, rhs = f.relation(v)
        for n in coeffs:
            if sympy.simplify(rhs - v.hi(n)) == 0:
                spec = v.tab[n]
                c = sympy.simplify(lhs / (eps**spec.q * L**spec.p))
                if not c.free_symbols and c.is_positive:
                    out[n] = min(out.get(n, c), c, key=lambda e: float(e))
    return out


def synthesize(dim: int, progress=None, system=None) -> Synthesis:
    """The smallest coefficients (bottom-up order :data:`ORDER`; T−, T, T+) for which
    every constraint of ``fperr verify`` holds for every ε ≤ 1e-5, to within 1 %.
    ``progress(name, field, value)`` is called after each coefficient. ``system``: the
    constraint system (default :class:`PaperSystem`; a user's declaration, with its own
    table, facts and order)."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, not {dim!r}")
    t0 = time.perf_counter()
    system = system or PaperSystem(dim)
    probe = _Probe(dim, system)
    coeffs = {n: {f: getattr(s, f) for f in FIELDS} for n, s in system.base.items()}
    if not probe(coeffs):
        bad = ", ".join(probe.failing(coeffs))
        raise RuntimeError(f"the {system.label} {dim}D table does not verify ({bad}): "
                           "nothing to start from")
    for name in system.order:
        for f in FIELDS:
            coeffs = _lower(probe, coeffs, name, f)
            if progress:
                progress(name, f, coeffs[name][f])
        coeffs = _raise_lo(probe, coeffs, name)
        if progress:
            progress(name, "lo (raised)", coeffs[name]["lo"])
    eqs = []
    for n, c in _fact_equalities(dim, coeffs, system).items():
        trial = {k: dict(v) for k, v in coeffs.items()}
        trial[n]["hi"] = c
        if probe(trial):
            coeffs, eqs = trial, eqs + [n]
    rep = system.verify(coeffs)   # the authoritative check, no memo
    if not rep.ok:
        raise RuntimeError("synthesized table does not verify: "
                           + ", ".join(o.id for o in rep.failures))
    return Synthesis(dim, coeffs, probe.count, time.perf_counter() - t0, eqs, rep,
                     dict(system.base), system.label)


def _text(x: sympy.Expr) -> str:
    return f'"{sympy.sstr(x)}"'


def to_toml(results: list[Synthesis], header: str = "") -> str:
    """The tables in the ``fperr verify --tolerances`` format (exact strings)."""
    lines = [f"# {h}" for h in header.splitlines()] if header else []
    for r in results:
        for n, f in r.coefficients.items():
            lines += ["", f"[{r.dim}.{n}]"]
            lines += [f"{k} = {_text(f[k])}" for k in FIELDS]
    return "\n".join(lines) + "\n"


def ratio_table(r: Synthesis) -> str:
    """One line per tolerance: paper and synthesized T−, T, T+ and their ratios."""
    out = [f"{r.dim}D  tolerance   {r.label + ' (T−, T, T+)':<28} synthesized (T−, T, T+)"
           "        ratio (T−, T, T+)"]
    for n, (a, b, c) in r.ratios().items():
        spec = (r.base or TABLES[r.dim])[n]
        pap = ", ".join(f"{float(getattr(spec, k)):.4g}" for k in FIELDS)
        syn = ", ".join(f"{float(r.coefficients[n][k]):.4g}" for k in FIELDS)
        out.append(f"    {n:<10} {pap:<28} {syn:<30} {a:.3f}, {b:.3f}, {c:.3f}")
    return "\n".join(out)


#: the table formats ``fperr synthesize -o``/``--check`` handle, by extension; both are
#: read back by ``fperr verify --tolerances`` (:func:`proofs.tables.load_overrides`)
TABLE_FORMATS = (".toml", ".json")


def to_json(results: list[Synthesis]) -> str:
    """The tables as JSON in the ``fperr verify --tolerances`` format (exact strings;
    JSON has no comments, so no header)."""
    import json

    return json.dumps({str(r.dim): {n: {k: sympy.sstr(f[k]) for k in FIELDS}
                                    for n, f in r.coefficients.items()}
                       for r in results}, indent=1, ensure_ascii=False) + "\n"


def render(results: list[Synthesis], suffix: str, module: str | None = None) -> str:
    """The file ``fperr synthesize -o FILE`` writes, in the format of its extension
    ``suffix`` (one of :data:`TABLE_FORMATS`)."""
    if suffix.lower() == ".json":
        return to_json(results)
    dims = ",".join(str(r.dim) for r in results)
    how = f"--predicates {module}" if module else f"--dim {dims}"
    return to_toml(results, (
        f"Generated by `fperr synthesize {how}`: the smallest coefficients the\n"
        "constraint system of `fperr verify` accepts (to within 1 %). Do not edit;\n"
        "regenerate. Coefficients of ε^q·L^p, exact."))


def write(path: str | Path, results: list[Synthesis], module: str | None = None) -> None:
    """Write the tables to ``path``: TOML or JSON as its extension says."""
    write_text_atomic(path, render(results, Path(path).suffix, module))


def is_current(text: str, results: list[Synthesis], suffix: str) -> bool:
    """Whether ``text``, a file of format ``suffix``, holds what a fresh synthesis writes
    (comments aside in TOML, layout aside in JSON)."""
    if suffix.lower() == ".json":
        import json

        try:
            return json.loads(text) == json.loads(to_json(results))
        except ValueError:
            return False
    return table_section(text) == table_section(to_toml(results))


def table_section(text: str) -> str:
    """The tables of a written file without its comment lines (for staleness checks)."""
    return "\n".join(l for l in text.splitlines() if l.strip() and not l.startswith("#"))
