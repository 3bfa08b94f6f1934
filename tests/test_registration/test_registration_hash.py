"""Registered pairs and weights are bit-identical to those of the registration before
the speed work of issue 12 (broad phase, face maps, suppression, chunking): a SHA-256 of
every kind's pairs and weights, rows sorted canonically, on mid-size W1/W2 cases. The
reference hashes were computed on main (eb60da0) before any change."""
from __future__ import annotations

import hashlib

import numpy as np
import pytest

import predicates

from predicates.registration import examples as meshes


def result_hash(res) -> str:
    """SHA-256 over every kind (registration order): counts, then the rows of
    (sim ids, cut ids, sim weights, cut weights) sorted by their ids."""
    h = hashlib.sha256()
    for kind in res.kinds:
        kp = res[kind]
        ids = np.concatenate([kp.sim, kp.cut], axis=1).astype(np.int64)
        order = np.lexsort(ids.T[::-1]) if len(ids) else np.zeros(0, dtype=np.int64)
        h.update(f"{kind}:{len(kp)}:{kp.candidates}:{kp.suppressed};".encode())
        for a in (kp.sim, kp.cut):
            h.update(np.ascontiguousarray(a[order], dtype=np.int64).tobytes())
        for w in (kp.sim_weights, kp.cut_weights):
            h.update(np.ascontiguousarray(w[order]).tobytes())
    return h.hexdigest()


def _case(name):
    dim, n, cut, kw = CASES[name][:4]
    if dim == 3:
        sim = meshes.cube_grid(n)
        cutm = (meshes.icosphere(kw["subdivisions"]) if cut == "sphere"
                else meshes.grid_plane(n, offset=(cut == "plane_offset")))
    else:
        sim = meshes.square_grid(n)
        cutm = (meshes.circle_polygon(kw["segments"]) if cut == "circle"
                else meshes.diagonal_cut(n))
    return sim, cutm


#: name -> (dim, n, cut, kwargs, tolerance_scale, dtype, reference hash on main eb60da0)
CASES = {
    "w1_n24_sphere5120": (3, 24, "sphere", {"subdivisions": 4}, 1.0, "float64",
        "ca1edba03367b3147a55490e1639d272b6a2f9243df7e253a6d8916a05a680c2"),
    "w1_n24_offset_plane": (3, 24, "plane_offset", {}, 1.0, "float64",
        "0878037d20056318658b163159d5f6c02abec509eef4260fd9870832ad798419"),
    "w1_n16_plane": (3, 16, "plane", {}, 1.0, "float64",
        "509147bd329ca4cb7f3bd633caa9f499285141876da2ac54afdf079467c50e7e"),
    "w1_n16_sphere1280_naive": (3, 16, "sphere", {"subdivisions": 3}, 0.0, "float64",
        "640213373f2b69b19e1d375444592b3eb34759f0885a88125bc0ec349d233e3c"),
    "w1_n16_sphere1280_f32": (3, 16, "sphere", {"subdivisions": 3}, 1.0, "float32",
        "63c55f21c8bd9bbb053859134f5ee83c85da8f091b4848fdddfb24ee53bb3011"),
    # re-pinned when circle_polygon's cos/sin became correctly rounded (9 of its 8192
    # coordinates moved by an ulp from libm's); the registration of the old polygon
    # still hashes to 8c6538cd…5807, so the registration itself did not change
    "w2_n256_circle4096": (2, 256, "circle", {"segments": 4096}, 1.0, "float64",
        "b6f97b5a2b75dcd5d2e7c22b2c2043eb52ae81d6e033d369b6cf278d21f429bf"),
    "w2_n128_diagonal": (2, 128, "diagonal", {}, 1.0, "float64",
        "71a206675fecd3bdd6c9f6f90aed411eca35e9b96778990bad1ced90b3126e74"),
    "w2_n96_circle1000_f32": (2, 96, "circle", {"segments": 1000}, 1.0, "float32",
        "56e2a910f369acdeb1400134bf1f8cb212b706a15e14427975a8a3e9813500c1"),
}


def run_case(name):
    (sp, sc), (cp, cc) = _case(name)
    ts, dtype = CASES[name][4], CASES[name][5]
    return predicates.intersect(sp, sc, cp, cc, dtype=dtype, tolerance_scale=ts)


@pytest.mark.parametrize("name", sorted(CASES))
def test_registration_bit_identical(name):
    res = run_case(name)
    assert sum(res.counts.values()) > 0  # the case registers something
    assert result_hash(res) == CASES[name][6]


if __name__ == "__main__":  # print the hashes (to refresh the references deliberately)
    for name in CASES:
        print(name, result_hash(run_case(name)))
