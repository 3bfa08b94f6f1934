"""Python text of the compiled kernels (:mod:`predicates.compiled.build` compiles it),
from a traced predicate (:mod:`predicates.compiled.trace`).

Two kernels per predicate and dtype:

* ``chain_<dtype>`` — given lanes (I1[q], I2[q]) of two simplex tables: gather, the
  predicate's statements, the accepted lanes' positions and weights;
* ``fused_<dtype>`` — the whole per-kind chain on a block of stage-1 pairs (face f,
  cutting cell C) of :mod:`predicates.registration.levels.facepairs`: every face g
  that C owns (or C itself), the exact box test of (f, g) at the kind's reach, the
  suppression pre-filter (a pair whose two simplices both have a face in a registered
  lower pair goes out to the exact numpy look-up, unevaluated), gather, predicate,
  output — no array of candidates at all. The candidates' coordinates are gathered
  into :data:`LANES` lanes; the predicate then runs on a full set of lanes in one loop
  without branches (``lanes_<dtype>``: every statement on every lane, a lane's
  rejections or-ed into its flag), which the compiler turns into vector instructions —
  the same IEEE operations one lane per element, no reassociation or contraction, so
  the same bits (benchmarks/README.md, "Part 2, eleventh pass"); the accepted lanes
  are written in candidate order (``flush_<dtype>``).

The box test is written out in the module per axis (not imported: the module's hash —
its file name, and with it numba's on-disk cache — covers every line it runs): the
broad phase's exact test (:func:`predicates.registration.spatial.broadphase.pair_test`),
F[lo_b − hi_a] ≤ pad and F[lo_a − hi_b] ≤ pad per axis, a NaN failing, with f's box
computed from its vertices (min and max exact: the same box) once per run of stage-1
pairs sharing f, and only for a cell C that owns a j-face (benchmarks/README.md, "Part
2, eighth pass"); f's coordinates read for its box fill its candidates' lanes (no
second gather; stage 1 lists a cell's pairs face by face, so the runs are long). The
cutting faces' boxes come as rows B[g] = (lo, hi) (:func:`predicates.compiled.chain.box_rows`):
one or two cache lines a test instead of 2d rows (benchmarks/README.md, "W1's fused
kernels and kinds (s21-kinds)").
"""
from __future__ import annotations

import re

from .trace import Program

__all__ = ["LANES", "chain_lines", "fused_lines"]

#: Candidates per predicate loop of the fused kernels (module docstring): W1's
#: triangle_edge kernels 35.6 → 25.3 ms at 256 lanes, 26 ms at 64, 52 ms at 1024.
LANES = 256
#: The lane buffers' row length: LANES + 8, an odd number of cache lines, so that a
#: lane's slots (one per row) fall in distinct sets of the L1 cache (2 KiB rows put a
#: lane's 15 slots in 2 sets of Zen 3's 8-way L1: W1's triangle_edge kernels 17.6 →
#: 16.5 ms; benchmarks/README.md, "W1's fused kernels and kinds (s21-kinds)").
STRIDE = LANES + 8

def gather(var: str, rows: str, points: str, first: int, count: int, dim: int,
           into: str = "x{k}") -> list[str]:
    """Statements loading ``count`` points of the simplex ``var`` (rows of ``rows``)
    into ``into`` (the coordinate k's variable, or a lane's slot: ``X[{k}, nl]``)."""
    out = []
    for p in range(count):
        out.append(f"v = np.uint64({rows}[{var}, {p}])")
        out += [f"{into.format(k=(first + p) * dim + a)} = {points}[v, {a}]"
                for a in range(dim)]
    return out


def body(prog: Program, dtype: str) -> list[str]:
    """The predicate's statements for one lane (``continue``: rejected)."""
    out = []
    for st in prog.lines:
        if st[0] == "let":
            out.append(f"{st[1]} = {st[2].replace('T(', f'np.{dtype}(')}")
        else:
            out.append(f"if {st[1]}:  # line {st[2]} of the algorithm: rejected")
            out.append("    continue")
    return out


def _lane(prog: Program, n1: int, dt: str, r1: str, r2: str) -> list[str]:
    n2, d = prog.n_points - n1, prog.dim
    return (gather(r1, "R1", "P1", 0, n1, d) + gather(r2, "R2", "P2", n1, n2, d)
            + body(prog, dt))


def _weights(prog: Program, out: str, row: str) -> list[str]:
    return [f"{out}[{row}, {k}] = {w.ref}" for k, w in enumerate(prog.weights)]


def chain_lines(prog: Program, n1: int, dt: str, opts: str) -> list[str]:
    """``chain_<dt>(P1, R1, I1, P2, R2, I2, tol, pos, out) -> count``."""
    lines = [f"@njit(**{opts})",
             f"def chain_{dt}(P1, R1, I1, P2, R2, I2, tol, pos, out):",
             f'    """{prog.name}: lanes I1[q] × I2[q]; accepted lanes to pos, out."""',
             "    count = 0",
             "    for q in range(I1.shape[0]):",
             "        r1 = I1[q]",
             "        r2 = I2[q]"]
    body_ = _lane(prog, n1, dt, "r1", "r2") + ["pos[count] = q"]
    body_ += _weights(prog, "out", "count") + ["count += 1"]
    return lines + ["        " + b for b in body_] + ["    return count", "", ""]


def _sim_box(count: int, dim: int) -> list[str]:
    """Statements setting (fl, fh) per axis to simplex f's box (``count`` vertices
    Rs[f], rows of Ps): :func:`predicates.registration.spatial.boxes.boxes_of`'s
    minimum/maximum fold, exact (a NaN propagates, as np.minimum's); f's coordinates
    kept as read (``s{k}``, point-major) for the lanes of its candidates."""
    out = []
    for p in range(count):
        out.append(f"v = np.uint64(Rs[np.uint64(f), {p}])")
        for a in range(dim):
            k = p * dim + a
            out.append(f"s{k} = Ps[v, {a}]")
            if p == 0:
                out += [f"fl{a} = np.float64(s{k})", f"fh{a} = fl{a}"]
            else:
                out += [f"x = np.float64(s{k})",
                        f"fl{a} = fl{a} if (fl{a} < x) | (fl{a} != fl{a}) else x",
                        f"fh{a} = fh{a} if (fh{a} > x) | (fh{a} != fh{a}) else x"]
    return out


def _cut_points(rows: str, points: str, first: int, count: int, dim: int,
                dt: str) -> list[str]:
    """Statements loading the cutting face g's ``count`` points into its lane's slots: a
    vertex (one point) in binary64 from its box row, whose low corner is the point itself
    (:func:`predicates.compiled.boxtest.boxes` of one point: the coordinates converted
    exactly, nothing folded) — the row the box test has just read, no dependent loads
    of g's vertex id and point (benchmarks/README.md, "W1's fused chain and validation,
    new angles (s24-w1)"); else gathered through ``rows`` (a binary32 kernel too:
    a conversion back from binary64 would quiet a signalling NaN's bits)."""
    if count == 1 and dt == "float64":
        return [f"X[{first * dim + a}, unl] = B[ug, {a}]" for a in range(dim)]
    return gather("ug", rows, points, first, count, dim, "X[{k}, unl]")


def _lanes_lines(prog: Program, dt: str, inline: str) -> list[str]:
    """``lanes_<dt>(X, n, tol, W, ok)``: the predicate on lanes 0…n−1 of ``X`` (a row
    per coordinate), every statement on every lane in source order (a rejected lane's
    later values are computed and never used: a NaN or an infinity, never an error,
    numba's numpy error model), its weights to ``W``, ok[q] = no rejection — no branch
    in the loop, so the compiler vectorizes it (module docstring)."""
    out = [f"@njit(**{inline})", f"def lanes_{dt}(X, n, tol, W, ok):"]
    # the tolerances read once (a store to W or ok might alias tol for the compiler)
    out += [f"    tol_{k} = tol[{k}]" for k in range(len(prog.tolerances))]
    body = [f"x{k} = X[{k}, q]" for k in range(prog.n_points * prog.dim)]
    rejections = []
    for st in prog.lines:
        if st[0] == "let":
            expr = re.sub(r"tol\[(\d+)\]", r"tol_\1", st[2].replace("T(", f"np.{dt}("))
            body.append(f"{st[1]} = {expr}")
        else:
            rejections.append(st[1])
    body += [f"W[{k}, q] = {w.ref}" for k, w in enumerate(prog.weights)]
    body.append(f"ok[q] = not ({' | '.join(rejections)})" if rejections else "ok[q] = True")
    return out + ["    for q in range(n):"] + ["        " + b for b in body] + ["", ""]


def _flush_lines(prog: Program, dt: str, inline: str) -> list[str]:
    """``flush_<dt>(X, lf, lg, n, …, nh) -> nh``: :func:`_lanes_lines` on n lanes, then
    the accepted ones' pairs (lf, lg) and weights appended to the output, in order."""
    out = [f"@njit(**{inline})",
           f"def flush_{dt}(X, lf, lg, n, tol, W, ok, out_s, out_c, out_w, nh):",
           f"    lanes_{dt}(X, n, tol, W, ok)",
           "    for u in range(n):",
           "        if ok[u]:",
           "            un = np.uint64(nh)  # unsigned: no wraparound test a store",
           "            out_s[un] = lf[u]",
           "            out_c[un] = lg[u]"]
    out += [f"            out_w[un, {k}] = W[{k}, u]" for k in range(len(prog.weights))]
    return out + ["            nh += 1", "    return nh", "", ""]


def fused_lines(prog: Program, n1: int, dt: str, opts: str, inline: str) -> list[str]:
    """``fused_<dt>(F, Cs, start, owned, has_tab, pad, Ps, Rs, B, flags, use_flags, swapped,
    P1, R1, P2, R2, tol, out_s, out_c, out_w, maybe_s, maybe_c, counts)`` (module
    docstring), after its helpers ``lanes_<dt>`` and ``flush_<dt>`` (compiled with
    ``inline``: in numba's IR of the kernel): cell C's owned j-faces are
    ``owned[start[C]:start[C + 1]]`` (in the owned table's column order: only faces it
    owns, no −1 slots to skip); counts = (candidates, hits, pairs left to the
    suppression look-up)."""
    nw = max(1, len(prog.weights))
    head = [f"@njit(**{opts})",
            f"def fused_{dt}(F, Cs, start, owned, has_tab, pad, Ps, Rs, B,",
            "             flag_s, flag_c, use_flags, swapped, P1, R1, P2, R2, tol, out_s,",
            "             out_c, out_w, maybe_s, maybe_c, counts):",
            f'    """{prog.name}: stage-1 pairs (F[q], Cs[q]) to registered pairs."""',
            f"    X = np.empty(({prog.n_points * prog.dim}, {STRIDE}), dtype=np.{dt})",
            f"    W = np.empty(({nw}, {STRIDE}), dtype=np.{dt})",
            f"    ok = np.empty({LANES}, dtype=np.bool_)",
            f"    lf = np.empty({LANES}, dtype=np.int64)  # the lanes' pairs (f, g)",
            f"    lg = np.empty({LANES}, dtype=np.int64)",
            "    nl = 0",
            "    ncand = 0",
            "    nh = 0",
            "    nm = 0",
            "    held = -1  # the simulation face whose box fl, fh hold"]
    head += ["    " + ", ".join(f"f{s}{a}" for s in "lh" for a in range(prog.dim))
             + " = " + ", ".join(["0.0"] * (2 * prog.dim))]
    head += [f"    s{k} = np.{dt}(0.0)" for k in range(max(n1, prog.n_points - n1) * prog.dim)]
    head += ["    for q in range(F.shape[0]):",
            "        f = F[q]",
            "        c = Cs[q]",
            "        uc = np.uint64(c)  # unsigned: no wraparound test per index (in range)",
            "        e0 = start[uc] if has_tab else 0",
            "        e1 = start[uc + np.uint64(1)] if has_tab else 1",
            "        if e0 == e1:  # C owns no j-face: f's box is not needed",
            "            continue"]
    # f's box computed from its vertices (no stored simulation face boxes) once per run
    # of pairs sharing f (the cell pairs T ascend: tetrahedron_vertex's), unrolled (its
    # vertex count: the predicate's first or second primitive's, as swapped says); the
    # test written out per axis (one subtraction and comparison each, as the numpy test)
    n2 = prog.n_points - n1
    head += ["        if f != held:", "            held = f"]
    if n1 == n2:
        head += ["            " + b for b in _sim_box(n1, prog.dim)]
    else:
        head += ["            if swapped:"] + ["                " + b for b in _sim_box(n2, prog.dim)]
        head += ["            else:"] + ["                " + b for b in _sim_box(n1, prog.dim)]
    head += ["        for e in range(np.uint64(e0), np.uint64(e1)):  # unsigned: owned[e]"]
    test = " and ".join(f"B[ug, {a}] - fh{a} <= pad and fl{a} - B[ug, {prog.dim + a}] <= pad"
                        for a in range(prog.dim))
    inner = ["g = owned[e] if has_tab else c",
             "ug = np.uint64(g)  # unsigned: no wraparound test a gather (ids in range)",
             f"if not ({test}):",
             "    continue",
             "ncand += 1",
             "if use_flags and flag_s[np.uint64(f)] and flag_c[ug]:  # maybe suppressed",
             "    maybe_s[np.uint64(nm)] = f",
             "    maybe_c[np.uint64(nm)] = g",
             "    nm += 1",
             "    continue"]
    # the simulation face's coordinates from its fold (s{k}), the cutting face's read
    d = prog.dim
    # the lane's slot unsigned: no wraparound test a store (benchmarks/README.md, "Part
    # 2, fourteenth pass": all fused kernels of W1 -0.7 to -1.3 ms)
    inner += (["unl = np.uint64(nl)", "if swapped:"]
              + ["    " + b for b in _cut_points("R1", "P1", 0, n1, d, dt)]
              + [f"    X[{n1 * d + k}, unl] = s{k}" for k in range(n2 * d)]
              + ["else:"] + [f"    X[{k}, unl] = s{k}" for k in range(n1 * d)]
              + ["    " + b for b in _cut_points("R2", "P2", n1, n2, d, dt)])
    flush = f"flush_{dt}(X, lf, lg, nl, tol, W, ok, out_s, out_c, out_w, nh)"
    inner += ["lf[unl] = f", "lg[unl] = g", "nl += 1",
              f"if nl == {LANES}:  # a full set of lanes: the predicate on them",
              f"    nh = {flush}",
              "    nl = 0"]
    tail = [f"    nh = {flush}", "    counts[0] = ncand", "    counts[1] = nh",
            "    counts[2] = nm", "", ""]
    return (_lanes_lines(prog, dt, inline) + _flush_lines(prog, dt, inline) + head
            + ["            " + b for b in inner] + tail)
