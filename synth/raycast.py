"""Exact ray intersections, vectorised over rays: round cones, elliptic discs, spheres, a plane.

Every function takes one origin ``o`` (3,) and unit directions ``d`` (..., 3) (float64) and returns the
ray parameter ``t`` (...) of the first hit in front of the origin (mm, ``inf`` on a miss).
"""

from __future__ import annotations

import numpy as np


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...k,...k->...", a, b)


def round_cone(o, d, pa, pb, ra: float, rb: float) -> np.ndarray:
    """First hit of the round cone spanned by spheres (pa, ra) and (pb, rb): a tapered cylinder piece.

    The surface is the convex hull of the two spheres (Inigo Quilez's closed form), so consecutive pieces
    of a polyline join without gaps and a free end is a spherical cap.
    """
    o, pa, pb = (np.asarray(v, np.float64) for v in (o, pa, pb))
    ba = pb - pa
    oa = o - pa
    ob = o - pb
    rr = ra - rb
    m0 = ba @ ba
    m1 = ba @ oa
    m2 = d @ ba
    m3 = d @ oa
    m5 = oa @ oa
    m6 = d @ ob
    m7 = ob @ ob
    d2 = m0 - rr * rr
    k2 = d2 - m2 * m2
    k1 = d2 * m3 - m1 * m2 + m2 * rr * ra
    k0 = d2 * m5 - m1 * m1 + m1 * rr * ra * 2.0 - m0 * ra * ra
    h = k1 * k1 - k0 * k2
    t = np.full(d.shape[:-1], np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        tb = (-np.sqrt(np.maximum(h, 0.0)) - k1) / k2
        y = m1 - ra * rr + tb * m2
        body = (h >= 0) & (y > 0) & (y < d2) & (tb > 0)
        t[body] = tb[body]
        h1 = m3 * m3 - m5 + ra * ra
        h2 = m6 * m6 - m7 + rb * rb
        t1 = np.where(h1 > 0, -m3 - np.sqrt(np.maximum(h1, 0.0)), np.inf)
        t2 = np.where(h2 > 0, -m6 - np.sqrt(np.maximum(h2, 0.0)), np.inf)
    caps = np.minimum(np.where(t1 > 0, t1, np.inf), np.where(t2 > 0, t2, np.inf))
    return np.where(body, t, caps)


def ellipse_disc(o, d, centre, normal, u_axis, v_axis, a: float, b: float, shape_power: float = 1.0):
    """First hit of a flat leaf: ``(s/a)^2 + ... <= 1`` in the plane through ``centre`` with unit ``normal``.

    ``u_axis``/``v_axis`` are unit in-plane axes, ``a``/``b`` the semi-axes (mm). With ``shape_power`` > 1 the
    outline is pointed at both ends of the u axis: ``|v/b| <= (1 - (u/a)^2)^shape_power``.

    Returns
    -------
    t, u, v : ndarray (...)
        Ray parameter (``inf`` on a miss) and the hit's coordinates on the leaf, scaled to [-1, 1].
    """
    o, centre, normal, u_axis, v_axis = (np.asarray(x, np.float64) for x in (o, centre, normal, u_axis, v_axis))
    den = d @ normal
    with np.errstate(invalid="ignore", divide="ignore"):
        t = ((centre - o) @ normal) / den
    rel_o = o - centre
    u = (rel_o @ u_axis + t * (d @ u_axis)) / a
    v = (rel_o @ v_axis + t * (d @ v_axis)) / b
    with np.errstate(invalid="ignore"):
        inside = (np.abs(den) > 1e-9) & (t > 0) & (np.abs(u) < 1) & \
            (np.abs(v) <= np.power(np.clip(1 - u * u, 0, 1), shape_power))
    return np.where(inside, t, np.inf), u, v


def sphere(o, d, centre, radius: float) -> np.ndarray:
    """First hit of a sphere (a ray starting inside it hits the far side)."""
    oc = np.asarray(o, np.float64) - np.asarray(centre, np.float64)
    b = d @ oc
    c = oc @ oc - radius * radius
    h = b * b - c
    with np.errstate(invalid="ignore"):
        sq = np.sqrt(np.maximum(h, 0.0))
    t0, t1 = -b - sq, -b + sq
    t = np.where(t0 > 0, t0, np.where(t1 > 0, t1, np.inf))
    return np.where(h >= 0, t, np.inf)


def plane_z(o, d_z, z_mm: float) -> np.ndarray:
    """Hit of the plane ``Z = z_mm`` (left camera frame) by the rays from ``o`` whose directions' Z components
    are ``d_z`` (the other components do not matter)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (z_mm - o[2]) / d_z
    return np.where(t > 0, t, np.inf)
