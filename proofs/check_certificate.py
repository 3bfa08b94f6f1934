"""Re-check a certificate written by ``fperr verify --certificate FILE``.

Usage: ``python -m proofs.check_certificate FILE``. Exit 0 when every constraint is
re-established for every ε ∈ (0, 1e-5], 1 naming each constraint that is not, 2 when the
file is malformed.

The checker trusts only exact rational arithmetic (:class:`fractions.Fraction`, Python
integers) and the code in this file: Sturm sequences count the distinct real roots of a
rational polynomial on an interval, signs at rational sample points are evaluated exactly,
square roots (and other rational powers) of rationals in coefficients are enclosed by
integer n-th roots. It imports neither sympy nor any fperr module, and shares no code with
the decision procedure (:mod:`proofs.decide`). Schema: docs/proofs.md, "Certificates".

What one inequality's record proves (ε = s⁴, L = 1 by homogeneity, S = ε_max^(1/4)):
lhs − rhs = num(s)/den(s); each of num, den carries a claimed sign σ (the same for both)
and a rational polynomial B with B_i ≤ σ·c_i coefficientwise, so σ·P(s) ≥ B(s) for s > 0.
B = s^k·Q(s) with Q(0) ≠ 0, and Q > 0 on (0, S] is shown either by dominance
(Q(0) > Σ_{i>0} |Q_i|·s_max^i with s_max ≥ S) or by a partition of (0, s_end], s_end ≥ S,
into gaps (no root, by Sturm; the sign at a sample point) and isolating intervals of
single roots that lie beyond S.
"""
from __future__ import annotations

import json
import sys
from fractions import Fraction

FORMAT = "fperr-certificate"
VERSION = 1
EPS_MAX = Fraction(1, 100000)


class Malformed(ValueError):
    """The file does not follow the schema."""


class NotCertified(Exception):
    """The record is well-formed but does not establish its claim."""


# -- reading --------------------------------------------------------------------------------

def _get(obj, key: str, kind, where: str):
    if not isinstance(obj, dict):
        raise Malformed(f"{where}: expected an object, got {type(obj).__name__}")
    if key not in obj:
        raise Malformed(f"{where}: missing field '{key}'")
    val = obj[key]
    if kind is int and isinstance(val, bool) or not isinstance(val, kind):
        raise Malformed(f"{where}: field '{key}' has type {type(val).__name__}")
    return val


def rational(text, where: str) -> Fraction:
    """A rational written "p/q" or "p" (integers); floats are refused (not exact)."""
    if not isinstance(text, str):
        raise Malformed(f"{where}: rational must be a string \"p/q\", got {text!r}")
    parts = text.strip().split("/")
    try:
        if len(parts) == 1:
            return Fraction(int(parts[0]))
        if len(parts) == 2 and int(parts[1]) > 0:
            return Fraction(int(parts[0]), int(parts[1]))
    except ValueError:
        pass
    raise Malformed(f"{where}: not a rational \"p/q\": {text!r}")


# -- exact polynomial arithmetic (ascending coefficient lists) -----------------------------

def trim(p: list) -> list:
    p = list(p)
    while p and p[-1] == 0:
        p.pop()
    return p


def sign_at(p: list, x: Fraction) -> int:
    """Exact sign of p(x) (Horner over the integers: p(n/d)·d^deg)."""
    n, d = x.numerator, x.denominator
    den = 1
    for c in p:
        den = den * c.denominator // _gcd(den, c.denominator)
    ints = [int(c * den) for c in p]
    deg = len(ints) - 1
    total = sum(a * n**i * d**(deg - i) for i, a in enumerate(ints))
    return (total > 0) - (total < 0)


def _gcd(a: int, b: int) -> int:
    while b:
        a, b = b, a % b
    return a


def _primitive(p: list) -> list:
    """p scaled by a positive rational to integer coefficients with gcd 1."""
    den = 1
    for c in p:
        den = den * c.denominator // _gcd(den, c.denominator)
    ints = [int(c * den) for c in p]
    g = 0
    for a in ints:
        g = _gcd(g, abs(a))
    return [Fraction(a // g) for a in ints] if g else ints


def _rem(a: list, b: list) -> list:
    a = list(a)
    while len(a) >= len(b) and a:
        f = a[-1] / b[-1]
        shift = len(a) - len(b)
        for i, c in enumerate(b):
            a[shift + i] -= f * c
        a = trim(a)
    return a


def sturm_sequence(p: list) -> list:
    """p, p', −rem(...) ..., each scaled by a positive constant (signs unchanged)."""
    p = _primitive(trim(p))
    seq = [p]
    dp = trim([i * c for i, c in enumerate(p)][1:])
    if dp:
        seq.append(_primitive(dp))
    while len(seq) > 1 and len(seq[-1]) > 1:
        r = trim([-c for c in _rem(seq[-2], seq[-1])])
        if not r:
            break
        seq.append(_primitive(r))
    return seq


def _variations(seq: list, x: Fraction) -> int:
    signs = [sg for sg in (sign_at(q, x) for q in seq) if sg != 0]
    return sum(1 for u, v in zip(signs, signs[1:]) if u != v)


def count_roots(seq: list, lo: Fraction, hi: Fraction) -> int:
    """Distinct real roots in (lo, hi) of the polynomial with Sturm sequence ``seq``
    (Sturm's theorem; lo < hi, neither a root — also valid for non-square-free p)."""
    return _variations(seq, lo) - _variations(seq, hi)


# -- coefficients with radicals ----------------------------------------------------------

def _iroot(n: int, k: int) -> int:
    """floor(n^(1/k)) for an integer n ≥ 0."""
    if n < 2:
        return n
    lo, hi = 0, 1 << (n.bit_length() // k + 1)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if mid**k <= n:
            lo = mid
        else:
            hi = mid
    return lo


def _power_enclosure(base: Fraction, exp: Fraction, bits: int) -> tuple:
    """Rationals lo ≤ base^exp ≤ hi (base > 0), hi − lo ≤ 2^-bits·(scale)."""
    x = base ** exp.numerator
    k = exp.denominator
    w = x.numerator * 2 ** (k * bits)
    t = _iroot(w // x.denominator, k)
    return Fraction(t, 2**bits), Fraction(t + 1, 2**bits)


def coefficient_enclosure(coef, bits: int, where: str) -> tuple:
    """(lo, hi) rationals enclosing an exact coefficient ("p/q" or {"terms": ...})."""
    if isinstance(coef, str):
        c = rational(coef, where)
        return c, c
    terms = _get(coef, "terms", list, where)
    lo = hi = Fraction(0)
    for j, term in enumerate(terms):
        w = f"{where}.terms[{j}]"
        if not (isinstance(term, list) and len(term) == 2 and isinstance(term[1], list)):
            raise Malformed(f"{w}: expected [\"p/q\", [[base, exponent], ...]]")
        r = rational(term[0], w)
        flo = fhi = Fraction(1)
        for f in term[1]:
            if not (isinstance(f, list) and len(f) == 2):
                raise Malformed(f"{w}: factor must be [\"base\", \"exponent\"]")
            b, e = rational(f[0], w), rational(f[1], w)
            if b <= 0:
                raise Malformed(f"{w}: radical base must be positive, got {b}")
            plo, phi = _power_enclosure(b, e, bits)
            flo, fhi = flo * plo, fhi * phi
        lo, hi = (lo + r * flo, hi + r * fhi) if r >= 0 else (lo + r * fhi, hi + r * flo)
    return lo, hi


def check_bound(coefs: list, sgn: int, bound: list, where: str) -> None:
    """B_i ≤ σ·c_i for every i (so σ·P(s) ≥ B(s) for s > 0)."""
    if len(coefs) != len(bound):
        raise Malformed(f"{where}: 'bound' and 'coefficients' differ in length")
    for i, (c, b) in enumerate(zip(coefs, bound)):
        for bits in (256, 1024, 4096):
            lo, hi = coefficient_enclosure(c, bits, f"{where}.coefficients[{i}]")
            lo, hi = (lo, hi) if sgn > 0 else (-hi, -lo)
            if b <= lo:
                break
            if b > hi:
                raise NotCertified(f"{where}: bound[{i}] = {b} exceeds the coefficient")
        else:
            raise NotCertified(f"{where}: bound[{i}] not shown ≤ the coefficient")


# -- evidence ------------------------------------------------------------------------------

def below_S(x: Fraction) -> bool:
    """x < S = EPS_MAX^(1/4), exactly."""
    return x < 0 or x**4 < EPS_MAX


def check_positive(bound: list, evidence, s_max: Fraction, where: str) -> None:
    """B(s) > 0 for every s ∈ (0, S], from the recorded evidence (raises NotCertified)."""
    method = _get(evidence, "method", str, where)
    nz = [i for i, c in enumerate(bound) if c != 0]
    if not nz:
        raise NotCertified(f"{where}: polynomial is identically zero")
    q = bound[nz[0]:]   # B = s^k·q, s^k > 0 on (0, S]
    if method == "dominance":
        tail = sum((abs(c) * s_max**i for i, c in enumerate(q) if i > 0), Fraction(0))
        if not q[0] > tail:
            raise NotCertified(f"{where}: dominance fails: {q[0]} ≤ Σ|q_i|·s_max^i")
        return
    if method != "isolation":
        raise Malformed(f"{where}: unknown evidence method {method!r}")
    pieces = _get(evidence, "pieces", list, where)
    if not pieces:
        raise Malformed(f"{where}: no pieces")
    seq = sturm_sequence(q)
    prev = Fraction(0)
    for j, pc in enumerate(pieces):
        w = f"{where}.pieces[{j}]"
        kind = _get(pc, "kind", str, w)
        lo, hi = rational(_get(pc, "lo", str, w), w), rational(_get(pc, "hi", str, w), w)
        if lo != prev or not lo < hi:
            raise NotCertified(f"{w}: pieces do not partition (0, s_end] ([{lo}, {hi}])")
        if sign_at(q, hi) == 0:
            raise NotCertified(f"{w}: piece end {hi} is a root")
        n = count_roots(seq, lo, hi)
        if kind == "gap":
            x = rational(_get(pc, "sample", str, w), w)
            sg = _get(pc, "sign", int, w)
            if n != 0:
                raise NotCertified(f"{w}: gap [{lo}, {hi}] contains {n} root(s)")
            if not lo < x < hi or sign_at(q, x) != sg:
                raise NotCertified(f"{w}: sign at sample {x} is not {sg}")
            if below_S(lo) and sg <= 0:
                raise NotCertified(f"{w}: negative on s ∈ ({lo}, {hi}), "
                                   f"ε ∈ ({float(lo)**4:.4g}, {float(hi)**4:.4g})")
        elif kind == "root":
            if n != 1:
                raise NotCertified(f"{w}: ({lo}, {hi}) holds {n} roots, not 1")
            if below_S(lo):
                raise NotCertified(f"{w}: a root at or below S, in s ∈ ({lo}, {hi}), "
                                   f"ε ∈ ({float(lo)**4:.4g}, {float(hi)**4:.4g})")
        else:
            raise Malformed(f"{w}: unknown piece kind {kind!r}")
        prev = hi
    if below_S(prev):
        raise NotCertified(f"{where}: pieces end at {prev} < S")


def check_polynomial(poly, s_max: Fraction, where: str) -> int:
    """Certify the claimed sign of one polynomial on (0, S]; returns that sign."""
    coefs = _get(poly, "coefficients", list, where)
    sgn = _get(poly, "sign", int, where)
    if sgn not in (1, -1):
        raise Malformed(f"{where}: sign must be 1 or -1")
    bound = [rational(b, f"{where}.bound") for b in _get(poly, "bound", list, where)]
    check_bound(coefs, sgn, bound, where)
    check_positive(bound, _get(poly, "evidence", dict, where), s_max, where)
    return sgn


def check_inequality(ineq, s_max: Fraction, where: str) -> None:
    """lhs > rhs (or ≥) on ε ∈ (0, EPS_MAX]: num/den > 0, or lhs − rhs ≡ 0 for ≥."""
    strict = _get(ineq, "strict", bool, where)
    if "unsupported" in ineq:
        raise NotCertified(f"{where}: no certificate: {ineq['unsupported']}")
    if _get(ineq, "identical", bool, where):
        if strict:
            raise NotCertified(f"{where}: lhs ≡ rhs, so lhs > rhs is false")
        return
    sn = check_polynomial(_get(ineq, "numerator", dict, where), s_max, where + ".numerator")
    sd = check_polynomial(_get(ineq, "denominator", dict, where), s_max,
                          where + ".denominator")
    if sn != sd:
        raise NotCertified(f"{where}: numerator and denominator have opposite signs")


def check_constraint(c: dict, s_max: Fraction, where: str) -> str | None:
    """None when the constraint is re-established, else the reason."""
    ineqs = _get(c, "inequalities", list, where)
    args = _get(c, "arguments", list, where)
    rule = _get(c, "argument_rule", str, where)
    error = c.get("error")
    try:
        for j, i in enumerate(ineqs):
            check_inequality(i, s_max, f"{where}.inequalities[{j}]")
    except NotCertified as e:
        return str(e)
    if error is not None:
        return f"recorded as not formed: {error}"
    if not args:
        return None if ineqs else "no inequality recorded"
    if rule not in ("any", "all"):
        raise Malformed(f"{where}: argument_rule must be 'any' or 'all'")
    reasons = []
    for j, a in enumerate(args):
        w = f"{where}.arguments[{j}] ({_get(a, 'name', str, where)})"
        try:
            for k, st in enumerate(_get(a, "steps", list, w)):
                for m, i in enumerate(_get(st, "inequalities", list, w)):
                    check_inequality(i, s_max, f"{w}.steps[{k}].inequalities[{m}]")
        except NotCertified as e:
            reasons.append(str(e))
            if rule == "all":
                return str(e)
            continue
        if rule == "any":
            return None
    return None if rule == "all" else "no argument re-established: " + "; ".join(reasons)


def check(doc) -> dict:
    """{constraint id: None (re-established) or reason}; raises Malformed."""
    if _get(doc, "format", str, "certificate") != FORMAT:
        raise Malformed(f"certificate: format is not {FORMAT!r}")
    if _get(doc, "version", int, "certificate") != VERSION:
        raise Malformed(f"certificate: version {doc['version']} (this checker reads {VERSION})")
    if rational(_get(doc, "eps_max", str, "certificate"), "eps_max") != EPS_MAX:
        raise Malformed(f"certificate: eps_max is not {EPS_MAX} (the range checked here)")
    s_max = rational(_get(doc, "s_max", str, "certificate"), "s_max")
    if s_max < 0 or s_max**4 < EPS_MAX:
        raise Malformed("certificate: s_max is below S = eps_max^(1/4)")
    out = {}
    for n, d in enumerate(_get(doc, "dims", list, "certificate")):
        where = f"dims[{n}]"
        ids = _get(d, "constraint_ids", list, where)
        entries = {}
        for j, c in enumerate(_get(d, "constraints", list, where)):
            cid = _get(c, "id", str, f"{where}.constraints[{j}]")
            if cid in entries or cid in out:
                raise Malformed(f"{where}: constraint {cid} appears twice")
            entries[cid] = c
        for cid in ids:
            if cid not in entries:
                out[cid] = "listed in constraint_ids but has no record"
        for cid, c in entries.items():
            if cid not in ids:
                out[cid] = "record not listed in constraint_ids"
            else:
                out[cid] = check_constraint(c, s_max, cid)
    return out


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1 or argv[0].startswith("-"):
        print("usage: python -m proofs.check_certificate FILE", file=sys.stderr)
        return 2
    try:
        with open(argv[0], encoding="utf-8") as f:
            doc = json.load(f)
        results = check(doc)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, Malformed) as e:
        print(f"check_certificate: malformed certificate {argv[0]}: {e}", file=sys.stderr)
        return 2
    bad = {cid: r for cid, r in results.items() if r is not None}
    for cid, r in bad.items():
        print(f"FAIL  {cid}: {r}")
    print(f"{len(results)} constraints, {len(results) - len(bad)} re-established with "
          f"exact rational arithmetic, {len(bad)} not")
    if bad:
        print("NOT CERTIFIED: " + ", ".join(bad))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
