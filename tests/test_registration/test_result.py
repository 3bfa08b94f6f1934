"""Issue 11, the result and the Python API: tolerances in input units, cut cells, points,
dict/DataFrame, repr/len/iteration, the vectorised inconsistency counters against a
pure-Python reference, numpy's gufunc convention of the predicates, parameter
validation, unreferenced vertices, trimesh/pyvista objects."""
from __future__ import annotations

import itertools
import json
from fractions import Fraction

import numpy as np
import pytest

import predicates
from predicates.registration.pictures.demo import degenerate_cases
from predicates.registration.examples import example
from predicates.registration.result.pairs import KIND_CODES
from predicates.tolerance_table import TABLES


def run(name, n, **kw):
    ex = example(name, n, **kw)
    return ex, predicates.intersect(*ex["sim"], *ex["cut"])


@pytest.mark.parametrize("scale", [1.0, 2.0 ** -30, 3.0e5])
def test_tolerances_are_in_input_units(scale):
    """res.tolerances = the scaled run's tolerances × 2^(e·p), exactly (Fraction), and
    for unit-size input they match predicates.tolerances(L_a, L_b) up to its rounding."""
    ex = example("zigzag", 6)
    res = predicates.intersect(ex["sim"][0] * scale, ex["sim"][1], ex["cut"][0] * scale,
                               ex["cut"][1])
    e = res.scale_exponent
    for name, spec in TABLES[2].items():
        scaled = Fraction(float(res._scaled_tolerances.values[name]))
        assert Fraction(res.tolerances.values[name]) == scaled * Fraction(2) ** (e * spec.p)
    assert Fraction(float(res.tolerances.L)) == \
        Fraction(float(res._scaled_tolerances.L)) * Fraction(2) ** e
    # τ is of the order of ε^(1/2)·L in input units whatever the scale
    tau = res.tolerances.values["tau"] / res.tolerances.L
    assert 1e-9 < tau < 1e-6
    assert res.tolerances_input_units()["tau"] == res.tolerances.values["tau"]


def _cut_cells_brute(res, kinds):
    out = []
    for i, cell in enumerate(res.sim_cells.tolist()):
        faces = {frozenset(c) for r in range(1, len(cell) + 1)
                 for c in itertools.combinations(cell, r)}
        if any(frozenset(s) in faces for k in kinds for s in res[k].sim.tolist()):
            out.append(i)
    return out


@pytest.mark.parametrize("name,n", [("circle", 6), ("plane_offset", 3), ("sphere", 2)])
def test_intersected_cells_against_brute_force(name, n):
    _, res = run(name, n)
    assert res.intersected_cells().tolist() == _cut_cells_brute(res, res.kinds)
    for k in res.kinds:
        assert res.intersected_cells(k).tolist() == _cut_cells_brute(res, [k])
    two = list(res.kinds[:2])
    assert res.intersected_cells(two).tolist() == _cut_cells_brute(res, two)
    with pytest.raises(KeyError, match="no kind"):
        res.intersected_cells("face_face")


def test_points_without_arguments_and_plain_data():
    ex, res = run("plane_offset", 3)
    for k, p in res.items():
        X = p.points()
        assert X.shape == (len(p), 3)
        np.testing.assert_array_equal(X, p.points(ex["sim"][0]))
        np.testing.assert_allclose(p.points(side="cut"), X, atol=1e-12)
    d = res.to_dict(pairs=True)
    back = json.loads(json.dumps(d))
    assert back["counts"] == res.counts and back["total"] == res.total
    assert back["tolerances"]["tau"] == res.tolerances.values["tau"]
    for k in res.kinds:
        assert back["pairs"][k]["sim"] == res[k].sim.tolist()
        assert np.allclose(np.reshape(back["pairs"][k]["points"], (-1, 3)), res[k].points())


def test_dataframe_has_flat_columns():
    """One row per pair, flat named columns (ids −1 padded, weights 0 padded), equal to
    the KindPairs arrays row by row."""
    pd = pytest.importorskip("pandas")
    _, res = run("circle", 5)
    df = res.to_dataframe()
    assert isinstance(df, pd.DataFrame) and len(df) == res.total
    assert list(df.columns) == ["kind", "sim_cell", "sim_0", "sim_1", "sim_2", "cut_0",
                                "cut_1", "w_sim_0", "w_sim_1", "w_sim_2", "w_cut_0",
                                "w_cut_1", "x", "y"]
    assert df["kind"].value_counts().to_dict() == {k: n for k, n in res.counts.items()}
    for kind in res.kinds:
        p, rows = res[kind], df[df["kind"] == kind]
        i, j = p.sim.shape[1], p.cut.shape[1]
        assert np.array_equal(rows[[f"sim_{c}" for c in range(i)]].to_numpy(), p.sim)
        assert (rows[[f"sim_{c}" for c in range(i, 3)]].to_numpy() == -1).all()
        assert np.array_equal(rows[[f"cut_{c}" for c in range(j)]].to_numpy(), p.cut)
        assert np.array_equal(rows[[f"w_sim_{c}" for c in range(i)]].to_numpy(),
                              p.sim_weights.astype(float))
        assert np.array_equal(rows[["x", "y"]].to_numpy(), p.points())
        assert np.array_equal(rows["sim_cell"].to_numpy(), p.sim_cell)


@pytest.mark.parametrize("name,n", [("circle", 6), ("sphere", 3), ("plane", 3)])
def test_sim_cell_is_the_lowest_cell_holding_the_primitive(name, n):
    """KindPairs.sim_cell against the definition, by brute force over all cells."""
    _, res = run(name, n)
    cells = [set(c) for c in res.sim_cells.tolist()]
    for kind in res.kinds:
        p = res[kind]
        for row, cell in zip(p.sim.tolist(), p.sim_cell.tolist()):
            want = next(c for c, vs in enumerate(cells) if set(row) <= vs)
            assert cell == want, (kind, row)


def test_result_is_a_mapping_of_kinds():
    from collections.abc import Mapping

    _, res = run("circle", 5)
    assert isinstance(res, Mapping)
    d = dict(res)
    assert list(d) == list(res.kinds) and all(d[k] is res[k] for k in res.kinds)
    assert set(res.keys()) == set(res.kinds) and res.get("no_such_kind") is None
    assert res == res and res != run("circle", 5)[1]  # a result equals only itself


def test_paraview_arrays_by_kind_name(tmp_path):
    """Per-kind 0/1 point arrays named by the kind besides the codes, through a VTU."""
    import meshio

    _, res = run("sphere", 3)
    path = tmp_path / "hits.vtu"
    meshio.write(path, res.to_meshio())
    back = meshio.read(path)
    codes = back.point_data["kind"]
    for kind in res.kinds:
        flag = back.point_data[f"is_{kind}"]
        assert flag.dtype == np.uint8 and set(np.unique(flag)) <= {0, 1}
        assert flag.sum() == len(res[kind]) == (codes == KIND_CODES[kind]).sum()
    assert np.array_equal(back.point_data["sim_cell"],
                          np.concatenate([res[k].sim_cell for k in res.kinds]))


def test_scale_exponent_is_what_the_summary_says():
    """input coordinates = used × 2^scale_exponent; the summary prints the factor used."""
    ex = example("circle", 4)
    (sp, sc), (cp, cc) = ex["sim"], ex["cut"]
    res = predicates.intersect(sp * 2.0 ** 40, sc, cp * 2.0 ** 40, cc)
    e = res.scale_exponent
    assert e > 30 and f"coordinates × 2^{-e} (exact; scale_exponent = {e}" in str(res)
    assert res.tolerances.L == predicates.intersect(sp, sc, cp, cc).tolerances.L * 2.0 ** 40


def test_repr_len_iteration():
    _, res = run("sphere", 2)
    r = repr(res)
    assert len(r) < 400 and r.startswith("<IntersectionResult 3D") and "\n" not in r
    assert len(res) == len(res.kinds) == 9 and list(res) == list(res.kinds)
    assert "edge_triangle" in res and "face" not in res
    assert repr(res["edge_triangle"]).startswith("<KindPairs edge_triangle")


def _broken_walks_reference(res) -> int:
    """The former pure-Python counter (sets of frozensets), as the oracle."""
    cells = set()
    for c in res.sim_cells.tolist():
        for r in range(1, len(c) + 1):
            cells.update(frozenset(x) for x in itertools.combinations(c, r))
    loc, events = {}, {}
    for kind in res.kinds:
        p = res[kind]
        if p.cut.shape[1] == 1:
            for s, c in zip(p.sim.tolist(), p.cut[:, 0].tolist()):
                loc.setdefault(c, []).append(frozenset(s))
        elif p.cut.shape[1] == 2:
            for s, c, w in zip(p.sim.tolist(), p.cut.tolist(), p.cut_weights.tolist()):
                key = tuple(sorted(c))
                events.setdefault(key, []).append((w[1] if c[0] == key[0] else w[0],
                                                   frozenset(s)))
    broken = 0
    for a, b in sorted({tuple(sorted(e)) for c in res.cut_cells.tolist()
                        for e in itertools.combinations(c, 2)}):
        if len(loc.get(a, ())) != 1 or len(loc.get(b, ())) != 1:
            continue
        walk = [loc[a][0]] + [x for _, x in sorted(events.get((a, b), []),
                                                  key=lambda e: e[0])] + [loc[b][0]]
        broken += any(x | y not in cells for x, y in zip(walk, walk[1:]))
    return broken


def test_vectorised_broken_walks_match_the_reference():
    total = 0
    for _, variants, inside in degenerate_cases(6):
        for sim, cut in variants[:4]:
            for ts in (1, 0):
                res = predicates.intersect(*sim, *cut, tolerance_scale=ts)
                ref = _broken_walks_reference(res)
                assert res.broken_walks() == ref
                total += ref
    assert total > 0  # the naive runs do break walks: the comparison is not vacuous


# -- predicates: numpy's gufunc convention -------------------------------------------------
def test_predicates_follow_the_gufunc_convention():
    from predicates import d3

    tol = predicates.tolerances(3, 1.0, 1.0)
    A, B, C = np.zeros(3), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    P, Q = np.array([0.2, 0.2, -1]), np.array([0.2, 0.2, 1])
    hit, w = d3.triangle_edge(A, B, C, P, Q, tol)
    assert hit.shape == () and bool(hit) and w.shape == (4,)
    ft = predicates.tolerances(3, 1.0, 1.0, float)
    h2, w2 = d3.triangle_edge(*(tuple(x) for x in (A, B, C, P, Q)), ft)
    assert h2 is True and np.allclose(w, w2)
    rng = np.random.default_rng(3)
    PP = rng.random((2, 4, 3)) - [0, 0, 1]
    hit, w = d3.triangle_edge(A, B, C, PP, Q, tol)
    assert hit.shape == (2, 4) and w.shape == (2, 4, 4)
    flat_h, flat_w = d3.triangle_edge(A[None], B[None], C[None], PP.reshape(-1, 3), Q[None],
                                      tol)
    assert np.array_equal(hit.ravel(), flat_h) and np.array_equal(w.reshape(-1, 4), flat_w)
    with pytest.raises(ValueError, match="do not broadcast"):
        d3.triangle_edge(A, B, C, rng.random((2, 3)), rng.random((3, 3)), tol)


# -- parameters ------------------------------------------------------------------------------
@pytest.mark.parametrize("kw, err, word", [
    ({"chunk": -1}, ValueError, "chunk"), ({"chunk": 0}, ValueError, "chunk"),
    ({"chunk": 2.5}, TypeError, "chunk"), ({"chunk": None}, TypeError, "chunk"),
    ({"chunk": True}, TypeError, "chunk"), ({"tolerance_scale": float("nan")}, ValueError,
                                             "tolerance_scale"),
    ({"tolerance_scale": "1"}, TypeError, "tolerance_scale"),
    ({"progress": "yes"}, TypeError, "progress"), ({"dtype": np.int32}, TypeError, "dtype"),
    ({"dtype": "nonsense"}, TypeError, "dtype")])
def test_every_parameter_is_validated_by_name(kw, err, word):
    ex = example("circle", 4, segments=12)
    with pytest.raises(err, match=word):
        predicates.intersect(*ex["sim"], *ex["cut"], **kw)


def test_small_chunks_give_the_same_result():
    ex, ref = run("circle", 8, segments=40)
    assert ref.total > 50
    res = predicates.intersect(*ex["sim"], *ex["cut"], chunk=7)
    assert res.counts == ref.counts


@pytest.mark.parametrize("far", [1e308, np.nan, -np.inf])
def test_an_unreferenced_vertex_does_not_matter(far):
    ex, ref = run("plane_offset", 3)
    for side in ("sim", "cut"):
        P, C = ex[side]
        P2 = np.vstack([P, [far, 0.0, 0.0]])
        args = [*ex["sim"], *ex["cut"]]
        args[0 if side == "sim" else 2] = P2
        assert predicates.intersect(*args).counts == ref.counts
        with pytest.warns(Warning, match="coarse resolution"):  # float32 at this size
            args32 = predicates.intersect(*args, dtype=np.float32)
        assert args32.total > 0


# -- mesh objects of other libraries -------------------------------------------------------
def test_trimesh_object_as_cutting_mesh():
    trimesh = pytest.importorskip("trimesh")
    ex = example("sphere", 3, subdivisions=1)
    tm = trimesh.Trimesh(vertices=ex["cut"][0], faces=ex["cut"][1], process=False)
    import meshio
    sim = meshio.Mesh(ex["sim"][0], [("tetra", ex["sim"][1])])
    assert predicates.intersect(sim, tm).counts == \
        predicates.intersect(*ex["sim"], *ex["cut"]).counts


def test_pyvista_objects():
    pv = pytest.importorskip("pyvista")
    ex = example("sphere", 3, subdivisions=1)
    P, T = ex["sim"]
    grid = pv.UnstructuredGrid({pv.CellType.TETRA: T}, P)
    C, F = ex["cut"]
    surf = pv.PolyData(C, np.column_stack([np.full(len(F), 3), F]).ravel())
    assert predicates.intersect(grid, surf).counts == \
        predicates.intersect(*ex["sim"], *ex["cut"]).counts


def test_unknown_objects_are_refused_by_type():
    ex = example("circle", 4, segments=12)
    with pytest.raises(TypeError, match="meshio.Mesh, a pyvista"):
        predicates.intersect(object(), object())
    import meshio
    with pytest.raises(TypeError, match="sim_region"):
        predicates.intersect(*ex["sim"], *ex["cut"], sim_region=1)
    m = meshio.Mesh(np.column_stack([ex["sim"][0], np.zeros(len(ex["sim"][0]))]),
                    [("triangle", ex["sim"][1])])
    assert predicates.intersect(m, meshio.Mesh(ex["cut"][0], [("line", ex["cut"][1])])).total


def test_intersect_files_validates_its_parameters_before_reading(tmp_path):
    from predicates.registration import intersect_files

    missing = tmp_path / "nope.vtu"  # never read: the parameters are refused first
    with pytest.raises(TypeError, match="dtype"):
        intersect_files(missing, missing, dtype="float16")
    with pytest.raises(TypeError, match="naive"):
        intersect_files(missing, missing, naive="no")
    with pytest.raises(TypeError, match="progress"):
        intersect_files(missing, missing, progress=None)


def test_pyvista_layouts_without_pyvista():
    """pyvista is optional and not installed here: its documented layouts (PolyData's
    padded [n, i0, .., i(n-1), ...] faces/lines, UnstructuredGrid's cells_dict keyed by
    VTK type ids) in plain objects convert to the same registration."""
    from types import SimpleNamespace

    ex = example("sphere", 3, subdivisions=1)
    P, T = ex["sim"]
    C, F = ex["cut"]
    grid = SimpleNamespace(points=P, cells_dict={10: T})  # VTK_TETRA = 10
    surf = SimpleNamespace(points=C, faces=np.column_stack([np.full(len(F), 3), F]).ravel(),
                           lines=np.zeros(0, np.int64))
    ref = predicates.intersect(*ex["sim"], *ex["cut"])
    assert predicates.intersect(grid, surf).counts == ref.counts
    quads = SimpleNamespace(points=C, faces=np.array([4, 0, 1, 2, 3]))
    with pytest.raises(ValueError, match="triangulate"):
        predicates.intersect(grid, quads)
