"""Meshes in and out: mesh objects (meshio, pyvista, trimesh) to arrays, guarded reading
of mesh files, checked and atomic writing, and the pair of files a command registers
(docs/design.md, "Files in and out")."""
