"""Guarded reading of mesh files (the inputs of section 1 of the paper).

meshio is a good reader of good files, but on bad ones it calls ``sys.exit(1)``, raises
raw numpy errors without the file name, prints blank lines on stdout, and two of its
readers (OFF, PLY) loop forever at the end of a file that holds only its header. Every
read here therefore (1) checks the file and the header of the formats whose readers can
hang, (2) runs meshio with stdout captured and, on the main thread, a time limit, and
(3) turns every failure into one :class:`MeshFileError` naming the file and the problem.
"""
from __future__ import annotations

import contextlib
import io
import os
import re
import signal
import threading
import warnings

import numpy as np

__all__ = ["MeshFileError", "read_mesh"]


class MeshFileError(ValueError):
    """A mesh file that cannot be used: ``str(e)`` is "PATH: problem"."""

    def __init__(self, path, problem):
        self.path, self.problem = os.fspath(path), str(problem).strip().splitlines()[0] \
            if str(problem).strip() else type(problem).__name__
        super().__init__(f"{self.path}: {self.problem}")

    def __reduce__(self):  # raised on a Dask worker (pieces read there), re-raised here
        return type(self), (self.path, self.problem)


def _ext(path: str) -> str:
    p = path.lower()
    for e in (".vol.gz", ".post.gz", ".dato.gz"):
        if p.endswith(e):
            return e
    return os.path.splitext(p)[1]


def _significant_lines(text: str):
    for line in text.splitlines():
        s = line.strip()
        if s and not s.startswith("#"):
            yield s


def _check_off(data: bytes) -> None:
    """OFF: "OFF", counts "nv nf ne", then at least 3·nv + 4·nf numbers (meshio reads
    exactly those; it loops forever when the counts line is missing)."""
    lines = _significant_lines(data.decode("utf-8", "replace"))
    if next(lines, None) != "OFF":
        raise ValueError("not an OFF file (the first line must read OFF)")
    counts = next(lines, None)
    if counts is None:
        raise ValueError("truncated OFF file: header only, no vertex/face counts")
    m = re.fullmatch(r"(\d+) (\d+) (\d+)", counts)
    if not m:
        raise ValueError(f"bad OFF counts line {counts[:40]!r} (expected 'vertices faces "
                         "edges', single spaces)")
    nv, nf = int(m.group(1)), int(m.group(2))
    have = sum(len(s.split()) for s in lines)
    if have < 3 * nv + 4 * nf:
        raise ValueError(f"truncated OFF file: the header announces {nv} vertices and {nf} "
                         f"triangles ({3 * nv + 4 * nf} numbers) but the body has {have}")


def _check_ply(data: bytes) -> None:
    """PLY: "ply", a format line and an "end_header" line (meshio loops forever
    without it)."""
    head = data.split(b"end_header", 1)
    lines = [s.strip() for s in head[0].decode("latin-1").splitlines() if s.strip()]
    if not lines or lines[0] != "ply":
        raise ValueError("not a PLY file (the first line must read ply)")
    if len(head) == 1:
        raise ValueError("truncated PLY file: the header does not end (no end_header line)")
    if len(lines) < 2 or not re.fullmatch(
            r"format (ascii|binary_little_endian|binary_big_endian) 1\.0", lines[1]):
        raise ValueError("bad PLY header: the second line must be 'format ascii 1.0' or "
                         "'format binary_little_endian/binary_big_endian 1.0'")


#: header checks of the formats whose meshio reader can hang
_CHECKS = {".off": _check_off, ".ply": _check_ply}


class _Timeout(Exception):
    pass


@contextlib.contextmanager
def _time_limit(seconds: float):
    """SIGALRM after ``seconds`` on the main thread (a backstop for reader loops);
    nothing elsewhere, or when the program has its own SIGALRM handler."""
    usable = (threading.current_thread() is threading.main_thread()
              and hasattr(signal, "setitimer")
              and signal.getsignal(signal.SIGALRM) in (signal.SIG_DFL, None))
    if not usable:
        yield
        return

    def fire(signum, frame):
        raise _Timeout()

    old = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _limit(size: int) -> float:
    """Seconds allowed for a file of ``size`` bytes: generous (1 min + 10 s per MB)."""
    return 60.0 + 10.0 * size / 1e6


def read_mesh(path: str | os.PathLike, *, time_limit: float | None = None):
    """Read a mesh file with meshio (any format it knows); every failure (missing,
    empty, unknown extension, truncated or corrupt file, a reader exceeding
    ``time_limit`` seconds) raises :class:`MeshFileError` ("PATH: problem")."""
    import meshio

    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"no such mesh file: {path}")
    if not os.path.isfile(path):
        raise MeshFileError(path, "not a regular file")
    ext = _ext(path)
    if ext not in meshio.extension_to_filetypes:
        raise MeshFileError(path, f"unknown mesh format '{ext or 'no extension'}' (meshio "
                                  "reads .msh, .vtu, .vtk, .mesh, .obj, .off, .stl, .ply, ...)")
    size = os.path.getsize(path)
    if size == 0:
        raise MeshFileError(path, "empty file")
    if ext in _CHECKS:
        try:
            with open(path, "rb") as fh:
                _CHECKS[ext](fh.read())
        except ValueError as e:
            raise MeshFileError(path, e) from None
    try:
        sink = io.StringIO()  # meshio prints blank lines, notes and errors of its own
        with _time_limit(time_limit or _limit(size)), contextlib.redirect_stdout(sink), \
                contextlib.redirect_stderr(sink), warnings.catch_warnings(), \
                np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            mesh = meshio.read(path)
    except _Timeout:
        raise MeshFileError(path, "the reader did not finish in time (corrupt or "
                                  "truncated file?)") from None
    except SystemExit:  # meshio's "Couldn't read file": sys.exit(1)
        raise MeshFileError(path, f"meshio cannot read it as {ext[1:]} (corrupt or "
                                  "truncated file?)") from None
    except MemoryError:
        raise MeshFileError(path, "corrupt file (its header announces more data than fits "
                                  "in memory)") from None
    except Exception as e:  # noqa: BLE001 - any reader failure is a bad file here
        raise MeshFileError(path, f"corrupt or truncated {ext[1:]} file ({e})") from None
    _check_read(mesh, path)
    return mesh


def _check_read(mesh, path: str) -> None:
    """What meshio returned is a mesh: 2D/3D points, cell blocks of index arrays."""
    pts = np.asarray(mesh.points)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or pts.dtype.kind not in "fiu":
        raise MeshFileError(path, f"corrupt file: points of shape {pts.shape}, dtype "
                                  f"{pts.dtype}")
    for b in mesh.cells:
        d = np.asarray(b.data)
        if d.ndim != 2 or d.dtype.kind not in "iu":
            raise MeshFileError(path, f"corrupt file: {b.type} cells of shape {d.shape}, "
                                      f"dtype {d.dtype}")
        if d.size and (d.min() < 0 or d.max() >= len(pts)):
            raise MeshFileError(path, f"corrupt file: a {b.type} cell refers to vertex "
                                      f"{int(d.max() if d.max() >= len(pts) else d.min())}"
                                      f" (the file has {len(pts)} points)")
