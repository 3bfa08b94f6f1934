"""Mesh objects to arrays (step 1 of :mod:`predicates.registration.pipeline`, the
inputs of section 1 of the paper): ``meshio.Mesh``, pyvista ``UnstructuredGrid`` /
``PolyData`` and trimesh ``Trimesh`` (duck-typed: neither is a dependency), cell-block
and gmsh physical-group selection, second-order elements through their corner nodes,
the boundary of a tetrahedral cutting mesh, and 2D meshes stored in a plane z = c.

Everything that changes what is registered (corner nodes only, boundary triangles, a
region) is reported in ``notes``, never silent.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from predicates.registration.levels.complex import single_rows

__all__ = ["Converted", "as_meshio", "common_plane", "convert_cut", "convert_pair", "plane_of",
           "convert_sim", "select_region"]

#: cell types used through their corner nodes: type -> (linear type, corners)
CORNERS = {"tetra": ("tetra", 4), "tetra10": ("tetra", 4), "triangle": ("triangle", 3),
           "triangle6": ("triangle", 3), "triangle7": ("triangle", 3), "line": ("line", 2),
           "line3": ("line", 2)}
#: VTK cell type ids (pyvista's cells_dict keys) of the types above
VTK_TYPES = {3: "line", 5: "triangle", 10: "tetra", 21: "line3", 22: "triangle6",
             24: "tetra10"}
#: VTK cell types that are not simplices: named in messages, never registered
VTK_OTHER = {1: "vertex", 9: "quad", 12: "hexahedron", 13: "wedge", 14: "pyramid",
             23: "quad8", 25: "hexahedron20", 26: "wedge15", 27: "pyramid13"}
#: volume cells fperr cannot take as they are (tetrahedra are needed)
VOLUMES = {"hexahedron", "wedge", "pyramid", "hexahedron20", "hexahedron27", "wedge15",
           "wedge18", "pyramid13", "pyramid14"}


@dataclass
class Converted:
    """One mesh as arrays, with what was done to it."""

    points: np.ndarray
    cells: np.ndarray
    notes: list = field(default_factory=list)
    plane: float | None = None  # z of a 2D mesh stored with 3 coordinates


def as_meshio(obj, role: str):
    """A ``meshio.Mesh`` (or an object with ``points`` and ``cells`` blocks) from a
    meshio mesh, a pyvista grid or a trimesh mesh; TypeError for anything else."""
    import meshio

    if isinstance(obj, meshio.Mesh):
        return obj
    if hasattr(obj, "vertices") and hasattr(obj, "faces"):  # trimesh.Trimesh
        return meshio.Mesh(np.asarray(obj.vertices), [("triangle", np.asarray(obj.faces))])
    if hasattr(obj, "cells_dict") and hasattr(obj, "points"):  # pyvista.UnstructuredGrid
        return _from_pyvista_grid(obj)
    if hasattr(obj, "points") and (hasattr(obj, "faces") or hasattr(obj, "lines")):
        return meshio.Mesh(np.asarray(obj.points), _polydata_blocks(obj))  # pyvista.PolyData
    if hasattr(obj, "points") and hasattr(obj, "cells"):
        return obj
    raise TypeError(f"the {role} mesh must be a meshio.Mesh, a pyvista UnstructuredGrid or "
                    f"PolyData, a trimesh.Trimesh or a (points, cells) tuple, got "
                    f"{type(obj).__name__}")


def _from_pyvista_grid(obj):
    """A pyvista UnstructuredGrid as a ``meshio.Mesh``: a block per cell type (vertices,
    quads, wedges... kept by name so that messages can name them; simplices used), with
    gmsh's physical groups carried over when the grid has them (cell data
    ``gmsh:physical`` and field data {name: [tag, dim]}, as meshio hands them to
    pyvista), so that regions select by tag or name as from the file."""
    import meshio

    kinds = getattr(obj, "celltypes", None)
    data = getattr(obj, "cell_data", None)
    phys = data.get("gmsh:physical") if data is not None and kinds is not None else None
    blocks, groups = [], []
    for t, conn in obj.cells_dict.items():
        name = VTK_TYPES.get(int(t)) or VTK_OTHER.get(int(t))
        if name is None:
            continue  # a variable-size or exotic VTK cell: nothing fperr can use
        blocks.append((name, np.asarray(conn)))
        if phys is not None:
            groups.append(np.asarray(phys)[np.asarray(kinds) == t])
    cell_data = {"gmsh:physical": groups} if phys is not None else {}
    field = {str(k): np.asarray(v) for k, v in getattr(obj, "field_data", {}).items()
             if np.asarray(v).dtype.kind in "iu"}
    return meshio.Mesh(np.asarray(obj.points), blocks, cell_data=cell_data,
                       field_data=field)


def _polydata_blocks(obj):
    """pyvista PolyData's padded cell arrays ([n, i0, .., i(n-1), n, ...]) as blocks."""
    out = []
    for attr, name, width in (("lines", "line", 2), ("faces", "triangle", 3)):
        flat = np.asarray(getattr(obj, attr, np.zeros(0, np.int64)), dtype=np.int64)
        if flat.size == 0:
            continue
        if flat.size % (width + 1) or np.any(flat[:: width + 1] != width):
            raise ValueError(f"pyvista PolyData {attr} must all have {width} vertices "
                             f"({name}s); triangulate it first (mesh.triangulate())")
        out.append((name, flat.reshape(-1, width + 1)[:, 1:]))
    return out


def select_region(mesh, region, role: str):
    """The cells of ``mesh`` in ``region``: a gmsh physical group (tag or name, from
    ``cell_data["gmsh:physical"]`` and ``field_data``), a meshio cell set (name) or a
    cell block (its index, when the file has no physical groups)."""
    import meshio

    phys = mesh.cell_data.get("gmsh:physical")
    names = {str(k): int(v[0]) for k, v in (mesh.field_data or {}).items()}
    text = str(region)
    tag = names.get(text)
    if tag is None and text.lstrip("-").isdigit():
        tag = int(text)
    if phys is not None and tag is not None:
        blocks = [(b.type, b.data[np.asarray(p) == tag]) for b, p in zip(mesh.cells, phys)]
        blocks = [b for b in blocks if len(b[1])]
        if not blocks:
            raise ValueError(f"the {role} mesh has no cells in physical group {region!r} "
                             f"(groups: {_groups(mesh, phys)})")
        return meshio.Mesh(mesh.points, blocks)
    sets = getattr(mesh, "cell_sets", None) or {}
    if text in sets:
        blocks = [(b.type, b.data[np.asarray(s, dtype=np.int64)])
                  for b, s in zip(mesh.cells, sets[text]) if s is not None and len(s)]
        return meshio.Mesh(mesh.points, blocks)
    if phys is None and tag is not None and 0 <= tag < len(mesh.cells):
        b = mesh.cells[tag]
        return meshio.Mesh(mesh.points, [(b.type, b.data)])
    choices = (f"physical groups: {_groups(mesh, phys)}" if phys is not None else
               f"cell blocks 0..{len(mesh.cells) - 1} "
               f"({', '.join(b.type for b in mesh.cells)})")
    lost = ("; its group names are not known (pyvista keeps gmsh's group tags but not "
            "their names): pass the tag, or read the file with meshio" if phys is not None
            and not mesh.field_data and not text.lstrip("-").isdigit() else "")
    raise ValueError(f"the {role} mesh has no region {region!r}; choose one of its {choices}"
                     + (f" or cell sets {', '.join(sets)}" if sets else "") + lost)


def _groups(mesh, phys) -> str:
    tags = sorted({int(t) for p in phys for t in np.unique(p)})
    inv = {int(v[0]): k for k, v in (mesh.field_data or {}).items()}
    return ", ".join(f"{t} ({inv[t]})" if t in inv else str(t) for t in tags) or "none"


def _blocks(mesh, linear: str, notes: list, role: str):
    """All cells whose corner type is ``linear``, as corner nodes (second-order elements
    lose their mid-edge nodes, with a note)."""
    out, higher = [], set()
    for b in mesh.cells:
        lin, k = CORNERS.get(b.type, (None, 0))
        if lin == linear:
            data = np.asarray(b.data)
            out.append(data[:, :k] if data.ndim == 2 else data)
            if b.type != lin:
                higher.add(b.type)
    if higher:
        notes.append(f"the {role} mesh has second-order cells ({', '.join(sorted(higher))}): "
                     "their corner nodes are used (straight-sided cells)")
    return np.concatenate(out) if out else None


def _types(mesh) -> str:
    return ", ".join(sorted({b.type for b in mesh.cells})) or "none"


def plane_of(points, role: str):
    """A 2D mesh stored with 3 coordinates: its (x, y) and the plane z = c it lies in."""
    pts = np.asarray(points)
    if pts.ndim != 2 or pts.shape[1] != 3:
        return pts, None
    if len(pts) == 0:
        return pts[:, :2], 0.0
    const = [bool(np.all(pts[:, j] == pts[0, j])) for j in range(3)]
    if const[2]:
        return pts[:, :2], float(pts[0, 2])
    if const[0] or const[1]:
        ax = "x" if const[0] else "y"
        raise ValueError(f"the {role} mesh is 2D but lies in the plane {ax} = "
                         f"{pts[0, 'xy'.index(ax)]:g}; 2D meshes must lie in a plane "
                         "z = const: swap its coordinates so that it does")
    raise ValueError(f"the {role} mesh has 2D cells but its points are not in one plane "
                     "z = const: a triangle surface in 3D cannot be a 2D simulation mesh")


def _boundary(tets: np.ndarray) -> np.ndarray:
    """The triangles that belong to exactly one tetrahedron."""
    faces = tets[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]].reshape(-1, 3)
    return faces[single_rows(np.sort(faces, axis=1))]


def _sim(mesh, role: str, notes: list):
    """(dim, points, cells, plane) of the simulation mesh."""
    tets = _blocks(mesh, "tetra", notes, role)
    if tets is not None:
        return 3, np.asarray(mesh.points), tets, None
    volumes = sorted({b.type for b in mesh.cells} & VOLUMES)
    if volumes:
        raise ValueError(f"the {role} mesh has {', '.join(volumes)} cells and no tetrahedra: "
                         "fperr needs a tetrahedral mesh; mesh the volume with tetrahedra "
                         "(gmsh: the default 3D algorithms without recombination) or split "
                         "each cell into tetrahedra")
    tris = _blocks(mesh, "triangle", notes, role)
    if tris is None:
        raise ValueError(f"the {role} mesh has no tetrahedra or triangles (cell types: "
                         f"{_types(mesh)}); a tetrahedral (3D) or triangle (2D) mesh is "
                         "needed: split its cells into tetrahedra/triangles first")
    pts = np.asarray(mesh.points)
    if pts.ndim == 2 and pts.shape[1] == 3 and not np.all(pts[:, 2] == pts[0, 2]) \
            and not (np.all(pts[:, 0] == pts[0, 0]) or np.all(pts[:, 1] == pts[0, 1])):
        raise ValueError(f"the {role} mesh is a triangle surface in 3D: a volume "
                         "(tetrahedral) mesh is needed as the simulation mesh in 3D")
    pts, plane = plane_of(pts, role)
    return 2, pts, tris, plane


def _cut(mesh, dim: int, role: str, notes: list):
    """(points, cells, plane) of the cutting mesh for a ``dim``-D simulation mesh."""
    if dim == 3:
        tris = _blocks(mesh, "triangle", notes, role)
        if tris is not None and _blocks(mesh, "tetra", [], role) is not None:
            notes.append(f"the {role} mesh has tetrahedra and triangles: its {len(tris)} "
                         "triangles are the cutting surface, the tetrahedra are ignored "
                         "(select a region to choose other cells)")
        if tris is None:
            tets = _blocks(mesh, "tetra", notes, role)
            if tets is None:
                raise ValueError(f"mixed dimensions: the simulation mesh has tetrahedra "
                                 f"(3D) but the {role} mesh has no triangles (cell types: "
                                 f"{_types(mesh)})")
            tris = _boundary(tets)
            notes.append(f"the {role} mesh is tetrahedral: its {len(tris)} boundary "
                         "triangles are used as the cutting surface")
        pts = np.asarray(mesh.points)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"mixed dimensions: 3D meshes need 3D points; the {role} "
                             f"mesh's points have shape {pts.shape}")
        return pts, tris, None
    lines = _blocks(mesh, "line", notes, role)
    if lines is None and _blocks(mesh, "triangle", [], role) is not None:
        raise ValueError(f"mixed dimensions: the simulation mesh has triangles only and the "
                         f"{role} mesh has triangles: a 2D registration needs line segments "
                         "as the cutting mesh, a 3D one a volume (tetrahedral) mesh is "
                         "needed as the simulation mesh")
    if lines is None:
        raise ValueError(f"mixed dimensions: the simulation mesh has triangles (2D) but the "
                         f"{role} mesh has no line segments (cell types: {_types(mesh)})")
    pts, plane = plane_of(mesh.points, role)
    return pts, lines, plane


def convert_sim(mesh, region=None) -> tuple[int, Converted]:
    """(dim, :class:`Converted`) of a simulation mesh object (:func:`as_meshio`)."""
    mesh = as_meshio(mesh, "simulation")
    if region is not None:
        mesh = select_region(mesh, region, "simulation")
    notes = []
    dim, pts, cells, plane = _sim(mesh, "simulation", notes)
    return dim, Converted(pts, cells, notes, plane)


def convert_cut(mesh, dim: int, region=None) -> Converted:
    """:class:`Converted` of a cutting mesh object for a ``dim``-D simulation mesh."""
    mesh = as_meshio(mesh, "cutting")
    if region is not None:
        mesh = select_region(mesh, region, "cutting")
    notes = []
    pts, cells, plane = _cut(mesh, dim, "cutting", notes)
    return Converted(pts, cells, notes, plane)


def common_plane(s: Converted, c: Converted) -> float | None:
    """The plane z = c both 2D meshes lie in (None: 2D points, or 3D)."""
    if s.plane is not None and c.plane is not None and s.plane != c.plane and len(c.cells):
        raise ValueError(f"the 2D meshes lie in different planes (z = {s.plane:g} and "
                         f"z = {c.plane:g})")
    return s.plane if s.plane is not None else c.plane


def convert_pair(sim, cut, sim_region=None, cut_region=None):
    """(sim, cut) :class:`Converted` from two mesh objects (see :func:`as_meshio`); the
    simulation mesh decides the dimension. Other cell blocks (boundary facets, vertex
    cells) are ignored; ``.plane`` of both is their common plane z = c."""
    dim, s = convert_sim(sim, sim_region)
    c = convert_cut(cut, dim, cut_region)
    s.plane = c.plane = common_plane(s, c)
    return s, c
