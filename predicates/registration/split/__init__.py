"""The virtual-node split of the simulation mesh along the cut (docs/split.md): the rules
on the registered pairs, the split mesh, its pictures and ``fperr cut``'s files. A layer
on top of the result: it receives an :class:`~predicates.registration.IntersectionResult`
(``res.split()`` is the shortcut) and is imported by nothing below it."""
from predicates.registration.split.mesh import SplitMesh, split_mesh
from predicates.registration.split.surface import CutSurface, cut_surface

__all__ = ["CutSurface", "SplitMesh", "cut_surface", "split_mesh"]
