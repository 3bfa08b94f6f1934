"""Vector arithmetic on points given as tuples of coordinates, for any number type.

Operation order is part of the error analysis (rules A–K are not associative), so it is
fixed here once: sums left to right, cross products as the paper writes them.
"""
from __future__ import annotations


def sub(p, q):
    """p − q componentwise."""
    return tuple(a - b for a, b in zip(p, q))


def scale(p, s):
    """Each component times s (s on the right, as û·(1/m))."""
    return tuple(a * s for a in p)


def dot(p, q):
    """p·q, summed left to right."""
    out = p[0] * q[0]
    for a, b in zip(p[1:], q[1:]):
        out = out + a * b
    return out


def cross2(p, q):
    """The 2D cross product p × q = p.x·q.y − p.y·q.x (a scalar)."""
    return p[0] * q[1] - p[1] * q[0]


def cross3(p, q):
    """The 3D cross product p × q."""
    return (p[1] * q[2] - p[2] * q[1],
            p[2] * q[0] - p[0] * q[2],
            p[0] * q[1] - p[1] * q[0])


def triple(p, q, r):
    """(p × q)·r: six times the signed volume spanned by p, q, r."""
    return dot(cross3(p, q), r)
