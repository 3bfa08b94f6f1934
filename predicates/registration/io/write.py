"""Writing results (section 1 of the paper's registration, for ParaView): output paths
checked before any work, and atomic writes.

Only a format that holds everything the result carries (points, cells, point and cell
data, field data with the kind legend) is accepted: VTU, ParaView's own. STL/OFF/PLY/
Medit keep no data, meshio's .msh picks an ANSYS writer that crashes, .obj/.xdmf fail,
and meshio writes no field data into .vtk — nor into .vtu, so the legend is added to
the VTU file here (a dataset-level ``<FieldData>``, which meshio and ParaView read).
A file is written to a temporary name in the target directory and renamed, so a failed
write never leaves a file, and an output naming an input file is refused.
"""
from __future__ import annotations

import contextlib
import io
import os
import tempfile
import threading

import numpy as np

__all__ = ["MESH_FORMATS", "PLOT_FORMATS", "check_output", "check_outputs", "write_atomic",
           "write_mesh", "write_text_atomic"]

#: the mesh formats a result is written in (they hold point, cell and field data)
MESH_FORMATS = (".vtu",)
#: the image formats :func:`predicates.registration.pictures.plot.plot_2d` writes
PLOT_FORMATS = (".png", ".pdf", ".svg")


def check_output(path: str | os.PathLike, kind: str) -> None:
    """Refuse an output path that cannot be written: its directory is missing, it is a
    directory, or its extension is not one of :data:`MESH_FORMATS` (``kind="mesh"``) or
    :data:`PLOT_FORMATS` (``kind="plot"``)."""
    path = os.fspath(path)
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise ValueError(f"{path}: directory {parent} does not exist")
    if os.path.isdir(path):
        raise ValueError(f"{path} is a directory; give a file name")
    ext = os.path.splitext(path)[1].lower()
    allowed = {"plot": PLOT_FORMATS, "mesh": MESH_FORMATS}[kind]
    if ext not in allowed:
        what = f"plots are written as {', '.join(allowed)}" if kind == "plot" else \
            (f"results are written as {', '.join(allowed)} (the format that keeps their "
             "kind, ids and weights as data, for ParaView)")
        raise ValueError(f"{path}: {what}, not '{ext or 'no extension'}'")


def _same(a: str, b: str) -> bool:
    if os.path.exists(a) and os.path.exists(b):
        return os.path.samefile(a, b)
    return os.path.realpath(a) == os.path.realpath(b)


def check_outputs(inputs: dict, outputs: dict) -> None:
    """Check every output (``{"-o": path, ...}``, kinds "mesh"/"plot" from
    :func:`check_output` by option) before any work: valid, not one of the ``inputs``
    (``{"SIM": path, ...}``: a typo must never overwrite the user's mesh), and no two
    outputs the same file."""
    seen = {}
    for (opt, kind), path in outputs.items():
        if path is None:
            continue
        check_output(path, kind)
        for name, src in inputs.items():
            if _same(os.fspath(path), os.fspath(src)):
                raise ValueError(f"{path}: the output {opt} names the input {name} file; "
                                 "refusing to overwrite it (choose another name)")
        for other, p in seen.items():
            if _same(os.fspath(path), p):
                raise ValueError(f"{path}: given to both {other} and {opt}")
        seen[opt] = os.fspath(path)


def write_atomic(path: str | os.PathLike, write) -> None:
    """Call ``write(tmp_path)`` on a temporary file beside ``path`` (same extension),
    then rename it to ``path``; on any failure the temporary file is removed and
    nothing is left at ``path``. The file gets the mode a plain ``open`` would give it,
    0o666 less the user's umask (``mkstemp`` makes it 0o600, private to the writer)."""
    path = os.fspath(path)
    d, base = os.path.split(os.path.abspath(path))
    ext = os.path.splitext(base)[1]
    fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=ext, dir=d)
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`write_atomic`): a report,
    table or certificate is either written whole or not at all."""
    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    write_atomic(path, write)


_UMASK_LOCK = threading.Lock()


def _umask() -> int:
    """The process's umask. Reading it means setting it, so it is set back at once (to
    0o077 meanwhile: a file another thread creates in between is private, never more
    open than asked), under a lock so two readers never see each other's 0o077."""
    with _UMASK_LOCK:
        mask = os.umask(0o077)
        os.umask(mask)
    return mask


def write_meshio(path: str | os.PathLike, mesh) -> None:
    """Write a ``meshio.Mesh`` atomically, meshio's stdout chatter kept off stdout, its
    ``field_data`` (integer arrays) included in a VTU file."""
    def write(tmp):
        with contextlib.redirect_stdout(io.StringIO()):
            mesh.write(tmp)
        if mesh.field_data and tmp.lower().endswith(".vtu"):
            _add_field_data(tmp, mesh.field_data)

    write_atomic(path, write)


def _add_field_data(path: str, field_data: dict) -> None:
    """Insert ``<FieldData>`` (ascii integer arrays) at the top of a VTU's grid."""
    arrays = "".join(
        f'<DataArray type="Int32" Name="{name}" NumberOfTuples="{np.size(v)}" '
        f'format="ascii">{" ".join(str(int(x)) for x in np.ravel(v))}</DataArray>\n'
        for name, v in field_data.items())
    with open(path, "rb") as fh:
        text = fh.read()
    tag = b"<UnstructuredGrid>"
    if tag not in text:
        raise ValueError(f"{path}: unexpected VTU layout, cannot add the field data")
    text = text.replace(tag, tag + b"\n<FieldData>\n" + arrays.encode() + b"</FieldData>", 1)
    with open(path, "wb") as fh:
        fh.write(text)


def write_mesh(path: str | os.PathLike, points: np.ndarray, cells: np.ndarray,
               cell_type: str, z: float = 0.0) -> None:
    """Write one cell block with meshio (2D points get z = ``z``, as mesh files
    expect)."""
    import meshio

    pts = np.asarray(points, dtype=np.float64)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.full(len(pts), z)])
    write_meshio(path, meshio.Mesh(pts, [(cell_type, np.asarray(cells))]))
