"""What "the same result" means for a registration run another way (partitioned, on
the workers, from pieces; docs/partitioned.md): every kind's pairs and weights bit for
bit, L, the exponent and the resolution report — and the example cases those tests
rotate exactly (predicates.portable: the same inputs on every machine)."""
from __future__ import annotations

import numpy as np

from predicates import portable
from predicates.registration.examples import example


def assert_identical(ref, res) -> None:
    """Same kinds, same pairs in the same order, bit-identical weights, same counts,
    the same global quantities and resolution report."""
    assert res.kinds == ref.kinds and res.counts == ref.counts
    assert res.scale_exponent == ref.scale_exponent and res.L_a == ref.L_a
    assert res.L_b == ref.L_b and res.resolution.to_dict() == ref.resolution.to_dict()
    for kind in ref.kinds:
        a, b = ref[kind], res[kind]
        for x, y in ((a.sim, b.sim), (a.cut, b.cut), (a.sim_weights, b.sim_weights),
                     (a.cut_weights, b.cut_weights)):
            assert x.dtype == y.dtype and x.shape == y.shape, kind
            assert x.tobytes() == y.tobytes(), kind


def rotated_case(name: str, n: int, angle=None, **kw):
    """(sim points, sim cells, cut points, cut cells) of ``example(name, n, **kw)``,
    both meshes rotated by the portable rotation ``angle`` when given."""
    ex = example(name, n, **kw)
    (sp, sc), (cp, cc) = ex["sim"], ex["cut"]
    if angle is not None:
        R = portable.rotation(ex["dim"], angle)
        sp, cp = portable.rotate(sp, R), portable.rotate(cp, R)
    return sp, np.asarray(sc), cp, cc


def chunked_cells(cells, rng, parts: int):
    """A dask array of the cells in ``parts`` random row chunks (dask must be installed)."""
    import dask.array as da

    cuts = np.sort(rng.choice(np.arange(1, len(cells)), min(parts, len(cells)) - 1,
                              replace=False)) if parts > 1 else []
    sizes = tuple(np.diff(np.concatenate([[0], cuts, [len(cells)]])).tolist())
    return da.from_array(cells, chunks=(sizes, cells.shape[1]))
