"""Out of memory in the serial registration after the plan (rank space, broad phase,
levels, after :func:`predicates.registration.pipeline._ranked`) is a clear refusal naming
the stage and what to do, not a bare MemoryError (docs/partitioned.md, section 2)."""
from __future__ import annotations

import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]

#: a process whose address space is capped, at the registration's entrance (the plan
#: done), to what it maps then plus a little: the registration's arrays cannot fit
LIMITED = """\
import resource, sys, unicodedata  # tqdm imports unicodedata lazily: mapped before
from predicates.registration import pipeline
real = pipeline.Registration
def limited(*a, **k):
    with open("/proc/self/status") as f:
        vm = next(int(l.split()[1]) * 1024 for l in f if l.startswith("VmSize:"))
    resource.setrlimit(resource.RLIMIT_AS, (vm + (2 << 20), resource.RLIM_INFINITY))
    return real(*a, **k)
pipeline.Registration = limited
"""
LIBRARY = LIMITED + """\
import predicates
from predicates.registration.examples import cube_grid, icosphere
try:
    predicates.intersect(*cube_grid(30), *icosphere(3))
except MemoryError as e:
    print(type(e).__name__, e)
"""


def _stages() -> str:
    from predicates.catalogue import kinds

    return "|".join(["rank space", "broad phase"] + [k.name for k in kinds(3)])


def test_an_address_space_limit_in_the_registration_is_a_clear_refusal():
    """With the address space capped once the plan is done, the run ends in
    RegistrationMemoryError (a MemoryError) naming a stage of the registration, the
    cells near the cut and what to do — measured: the registration of cube 30 ×
    icosphere 3 needs tens of MiB beyond the 2 MiB left."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "FPERR_ACCELERATE": "0"}
    r = subprocess.run([sys.executable, "-c", LIBRARY], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert re.fullmatch(
        rf"RegistrationMemoryError not enough memory for the registration \(({_stages()})\) "
        r"of meshes of 6 MiB, \d+ simulation and \d+ cutting cells near the cut: "
        r"partition the run .*--workers N --partitions K.* or run on a machine with more "
        r"memory \(MemoryError: .*\)\n", r.stdout), (r.stdout, r.stderr)


@pytest.mark.parametrize("where, stage", [
    (("pipeline", "Registration"), "rank space"),
    (("loop", "cell_pairs"), "broad phase"),
    (("loop.Registration", "_candidates"), "vertex_vertex"),
])
def test_out_of_memory_names_the_stage_of_the_registration(monkeypatch, where, stage):
    """The stage named is the one that ran out: the rank space, the cells' broad phase,
    or the kind being registered (accelerate=False: the numpy chain, whose kinds gather
    their candidates through ``_candidates``, vertex_vertex first). The cells near the
    plane z = 1/2: the two layers of 4² × 6 tetrahedra touching it, and the plane's 32
    triangles."""
    import predicates
    from predicates.registration import pipeline
    from predicates.registration.examples import cube_grid, grid_plane
    from predicates.registration.levels import loop

    def boom(*a, **k):
        raise MemoryError()

    owner = {"pipeline": pipeline, "loop": loop, "loop.Registration": loop.Registration}
    monkeypatch.setattr(owner[where[0]], where[1], boom)
    with pytest.raises(pipeline.RegistrationMemoryError,
                       match=rf"registration \({stage}\) of meshes of 0 MiB, 192 "
                             r"simulation and 32 cutting cells near the cut: .*"
                             r"\(MemoryError: no detail\)$"):
        predicates.intersect(*cube_grid(4), *grid_plane(4, k=2), accelerate=False)
