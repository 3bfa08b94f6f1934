"""A result as data for other tools: ParaView (meshio meshes with named, per-kind 0/1
arrays besides the codes), plain JSON-ready data and a flat pandas data frame. Every
consumer takes the cutting mesh as registered (possibly refined, docs/resolution.md) and
maps its points back to the cutting mesh as given."""
from __future__ import annotations

import numpy as np

from predicates.registration.result.pairs import KIND_CODES, pad_rows

__all__ = ["sim_mesh", "to_dataframe", "to_dict", "to_meshio"]


def to_dict(res, pairs: bool = False) -> dict:
    """:meth:`IntersectionResult.to_dict`."""
    out = {"dim": res.dim, "dtype": np.dtype(res.dtype).name,
           "naive": res.tolerance_scale == 0, "tolerance_scale": res.tolerance_scale,
           "simulation_cells": len(res.sim_cells), "cutting_cells": len(res.cut_cells),
           "counts": res.counts, "total": res.total,
           "candidates": {k: int(res.pairs[k].candidates) for k in res.kinds},
           "tolerances": res.tolerances_input_units(), "L_a": float(res.L_a),
           "L_b": float(res.L_b), "scale_exponent": int(res.scale_exponent),
           "plane_z": res.plane, "rounded_inputs": bool(res.rounded_inputs),
           "notes": list(res.notes) + res.status_notes(),
           "timings": {k: v if isinstance(v, list) else float(v)  # list: partitions
                       for k, v in res.timings.items()}}
    report = getattr(res, "resolution", None)
    if report is not None:
        out["resolution"] = report.to_dict() if hasattr(report, "to_dict") else report
    if pairs:
        out["pairs"] = {k: {"sim": p.sim.tolist(), "cut": p.cut.tolist(),
                            "sim_weights": p.sim_weights.astype(float).tolist(),
                            "cut_weights": p.cut_weights.astype(float).tolist(),
                            "sim_cell": p.sim_cell.tolist(),
                            "points": p.points().tolist()} for k, p in res.items()}
    return out


def _columns(res) -> dict:
    """Flat columns of every pair, kinds in registration order (ids −1 and weights 0
    padded to the widest primitive of the dimension)."""
    ws, wc = res.dim + 1, res.dim
    parts = [(k, p) for k, p in res.items() if len(p)]
    cat = (lambda arrs, shape, dt: np.concatenate(arrs) if arrs else np.zeros(shape, dt))
    sid = cat([pad_rows(p.sim, ws, -1) for _, p in parts], (0, ws), np.int64)
    cid = cat([pad_rows(p.cut, wc, -1) for _, p in parts], (0, wc), np.int64)
    sw = cat([pad_rows(p.sim_weights.astype(np.float64), ws, 0.0) for _, p in parts],
             (0, ws), np.float64)
    cw = cat([pad_rows(p.cut_weights.astype(np.float64), wc, 0.0) for _, p in parts],
             (0, wc), np.float64)
    X = cat([p.points() for _, p in parts], (0, res.dim), np.float64)
    cols = {"kind": [k for k, p in parts for _ in range(len(p))],
            "sim_cell": cat([p.sim_cell for _, p in parts], (0,), np.int64)}
    cols.update({f"sim_{j}": sid[:, j] for j in range(ws)})
    cols.update({f"cut_{j}": cid[:, j] for j in range(wc)})
    cols.update({f"w_sim_{j}": sw[:, j] for j in range(ws)})
    cols.update({f"w_cut_{j}": cw[:, j] for j in range(wc)})
    cols.update({name: X[:, j] for j, name in enumerate("xyz"[: res.dim])})
    if res.cut_refined:
        data = cut_input_data(res)
        cols["cut_input_cell"] = data["cut_input_cell"]
        cols.update({f"w_cut_input_{j}": data["cut_input_weights"][:, j] for j in range(wc)})
    return cols


def to_dataframe(res):
    """:meth:`IntersectionResult.to_dataframe`."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError("to_dataframe needs pandas (pip install pandas); "
                          "res.to_dict(pairs=True) gives the same as plain data") from None
    df = pd.DataFrame(_columns(res))
    df["kind"] = pd.Categorical(df["kind"], categories=list(res.kinds))
    return df


def cut_input_data(res) -> dict:
    """Every pair's cutting point on the cutting mesh as given: ``cut_input_cell`` (m,)
    and ``cut_input_weights`` (m, dim), kinds in registration order."""
    cells, weights = [], []
    for k in res.kinds:
        c, w = res.cut_input(k)
        cells.append(c)
        weights.append(w)
    return {"cut_input_cell": np.concatenate(cells),
            "cut_input_weights": np.concatenate(weights)}


def xyz(res, X: np.ndarray) -> np.ndarray:
    """Points in 3D for ParaView: a 2D mesh goes back into its plane z = c."""
    X = np.asarray(X, dtype=np.float64)
    if X.shape[1] == 2:
        X = np.column_stack([X, np.full(len(X), res.plane or 0.0)])
    return X


def _legend(res) -> dict:
    return {k: np.array([c], dtype=np.int32) for k, c in res.kind_legend().items()}


def to_meshio(res):
    """:meth:`IntersectionResult.to_meshio`."""
    import meshio

    cols = _columns(res)
    X = xyz(res, np.column_stack([cols[n] for n in "xyz"[: res.dim]]))
    kind = np.array([KIND_CODES[k] for k in cols["kind"]], dtype=np.int32)
    stack = (lambda prefix, w: np.column_stack([cols[f"{prefix}{j}"] for j in range(w)]))
    data = {"kind": kind, "sim_ids": stack("sim_", res.dim + 1),
            "cut_ids": stack("cut_", res.dim),
            "sim_weights": stack("w_sim_", res.dim + 1),
            "cut_weights": stack("w_cut_", res.dim), "sim_cell": cols["sim_cell"]}
    # one categorical 0/1 array per kind, named by it: ParaView colours and thresholds
    # these by name (``kind`` is a code, shown as a continuous colour bar)
    data.update({f"is_{k}": (kind == KIND_CODES[k]).astype(np.uint8) for k in res.kinds})
    if res.cut_refined:
        data["cut_input_cell"] = cols["cut_input_cell"]
        data["cut_input_weights"] = stack("w_cut_input_", res.dim)
    cells = [("vertex", np.arange(len(X), dtype=np.int64)[:, None])]
    return meshio.Mesh(X, cells, point_data=data, field_data=_legend(res))


def sim_mesh(res):
    """:meth:`IntersectionResult.sim_mesh`."""
    import meshio

    data = {}
    bits = np.zeros(len(res.sim_cells), dtype=np.int32)
    masks = res.cut_masks(res.kinds)
    for k in res.kinds:
        m = masks.get(k, np.zeros(len(res.sim_cells), dtype=bool))
        data[f"cut_by_{k}"] = m.astype(np.int8)
        bits |= m.astype(np.int32) << (KIND_CODES[k] - 1)
    data = {"cut": (bits != 0).astype(np.int8), "cut_kinds": bits, **data}
    ctype = "tetra" if res.dim == 3 else "triangle"
    return meshio.Mesh(xyz(res, res.sim_points), [(ctype, res.sim_cells)],
                       cell_data={k: [v] for k, v in data.items()}, field_data=_legend(res))
