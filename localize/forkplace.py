"""The parent's axis at a fork from its own outline (where the fork is placed, issue 5).

Near a crotch the parent's centre line (skeleton or fitted row middles) is pulled towards the
child: the child widens the silhouette on its side from where its back edge leaves the parent's
outline to where its front edge does. Cross-sections of the parent square to its axis, taken on
both sides of the fork outside that stretch, cross the parent alone; the middles of those whose
width is the parent's own lie on its axis (its two edges are parallel).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize import kernels
from appliance.localize.curves import median

# cross-sections per side, and their spacing (parent radii, at least this many px)
SECTIONS = 4
SECTION_STEP_R = 0.5
SECTION_STEP_MIN_PX = 3.0
# a section is the parent's alone when its width is within this of the parent's (fraction of the
# width, plus px): a child or an occluder merged with it widens it, a leaf narrows it
WIDTH_TOL = 0.25
WIDTH_TOL_PX = 2.0
# a section's middle further from the placed line than this (parent radii) is another shape's
MIDDLE_MAX_R = 0.5
# ... and within this of the sections' median width (fraction, plus px)
SAME_WIDTH = 0.08
SAME_WIDTH_PX = 1.5
# middles further than this from the line through all (px) are left out once (if 3 stay)
MIDDLE_OFF_PX = 1.0
# the axis taken only within this of the line it corrects (sine of the angle)
MAX_TURN_SIN = 0.10


def _tls(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Total-least-squares line through points (N, 2): centroid and unit direction."""
    c = pts.sum(0) / len(pts)                 # (the mean, without np.mean's checks)
    q = pts - c
    sxx, syy, sxy = float(np.dot(q[:, 0], q[:, 0])), float(np.dot(q[:, 1], q[:, 1])), float(np.dot(q[:, 0], q[:, 1]))
    ang = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    return c, np.array([np.cos(ang), np.sin(ang)])


@numba.njit(**kernels._JIT)
def _sections(mask, base, e, n, s, r, half):
    """:func:`section_middles`' scans, compiled: per section k (``s`` (K,)), from its sample nearest
    ``t = 0`` that is on (within ``MIDDLE_MAX_R`` r + 1) outwards to the first off sample each side
    (``t`` in -half..half, the mask read lazily by :func:`kernels.bilinear_u8`, cv2.remap's values).
    Returns per section (K, 3): found (1/0), middle t, width (px)."""
    K = len(s)
    T = 2 * half + 1
    out = np.zeros((K, 3))
    lim = MIDDLE_MAX_R * r + 1.0
    for k in range(K):
        bx, by = base[0] + s[k] * e[0], base[1] + s[k] * e[1]
        vals = np.full(T, -1.0)
        c = -1
        for dd in range(half + 1):
            if dd > lim:
                break
            for j in (half - dd, half + dd):
                if vals[j] < 0:
                    t = float(j - half)
                    vals[j] = kernels.bilinear_u8(mask, np.float32(bx + t * n[0]), np.float32(by + t * n[1]))
                if vals[j] >= 128.0:
                    c = j
                    break
            if c >= 0:
                break
        if c < 0:
            continue
        a = c - 1
        while a >= 0:
            if vals[a] < 0:
                t = float(a - half)
                vals[a] = kernels.bilinear_u8(mask, np.float32(bx + t * n[0]), np.float32(by + t * n[1]))
            if vals[a] < 128.0:
                break
            a -= 1
        b = c + 1
        while b < T:
            if vals[b] < 0:
                t = float(b - half)
                vals[b] = kernels.bilinear_u8(mask, np.float32(bx + t * n[0]), np.float32(by + t * n[1]))
            if vals[b] < 128.0:
                break
            b += 1
        if a < 0 or b >= T:                     # the section runs off its window
            continue
        va, vb = vals[a], vals[b]
        lo = (a - half) + (128.0 - va) / max(vals[a + 1] - va, 1e-9)
        hi = (b - half) - (128.0 - vb) / max(vals[b - 1] - vb, 1e-9)
        out[k, 0], out[k, 1], out[k, 2] = 1.0, 0.5 * (lo + hi), hi - lo
    return out


def section_middles(mask: np.ndarray, base: np.ndarray, e: np.ndarray, n: np.ndarray, s: np.ndarray,
                    r: float) -> np.ndarray:
    """Middles (M, 2) of the parent's cross-sections at ``base + s_k e`` (``s`` (K,), px) along ``n``.

    Each section is read on ``t`` in +-(2.5 r + 4) px, 1 px apart (bilinear); its run of coverage
    >= 128 through (or nearest within ``MIDDLE_MAX_R`` r + 1 px of) ``t = 0``, ends interpolated at
    128, is kept when its width is the parent's ``2 r`` (px) within ``WIDTH_TOL`` (and
    ``WIDTH_TOL_PX``), its middle within ``MIDDLE_MAX_R`` r + 1 px of ``t = 0``, and its width within
    ``SAME_WIDTH`` (and ``SAME_WIDTH_PX``) of the kept sections' median width.
    """
    if len(s) == 0:
        return np.zeros((0, 2))
    half = int(np.ceil(2.5 * r + 4.0))
    f = _sections(np.ascontiguousarray(mask), np.asarray(base, float), np.asarray(e, float),
                  np.asarray(n, float), np.asarray(s, float), float(r), half)
    ok = (f[:, 0] > 0) & (np.abs(f[:, 2] - 2.0 * r) <= WIDTH_TOL * 2.0 * r + WIDTH_TOL_PX) \
        & (np.abs(f[:, 1]) <= MIDDLE_MAX_R * r + 1.0)
    f, s = f[ok], s[ok]
    if len(f):       # the parent's own width is the sections' usual one: a wider or narrower one is merged
        w = float(median(f[:, 2]))          # (np.median's value)
        keep = np.abs(f[:, 2] - w) <= SAME_WIDTH * w + SAME_WIDTH_PX
        f, s = f[keep], s[keep]
    return base + s[:, None] * e + f[:, 1:2] * n


def parent_axis(mask: np.ndarray, xy: np.ndarray, e1: np.ndarray, out: np.ndarray, r_behind: float,
                r_ahead: float, r_child: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The parent's axis (centroid, unit direction) from its cross-sections clear of the crotch.

    ``xy`` (2,): the fork as placed on the parent's line of direction ``e1`` (2,); ``out`` (2,):
    the child's direction away from it; ``r_behind``, ``r_ahead``: the parent's radius (px) on
    the side opposite the child and on the child's side; ``r_child``: the child's (px).

    With the parent along x, the child leaving at angle a from the fork F, the child's back
    edge leaves the parent's outline at ``(r_child - R cos a) / sin a`` behind F (if positive) and
    its front edge at ``(R cos a + r_child) / sin a`` ahead of it: sections from half a parent
    radius (+3 px, for the fork's own place being a few px off) beyond those are the parent's
    alone. None when fewer than three sections hold, or the axis turns more than
    ``MAX_TURN_SIN`` from ``e1``.
    """
    e = e1 if float(np.dot(e1, out)) >= 0.0 else -e1
    n = np.array([-e[1], e[0]])
    cos_a = float(np.dot(e, out))
    sin_a = abs(float(e[0] * out[1] - e[1] * out[0]))
    if sin_a < 0.2:
        return None
    # (a side's radius read next to the crotch may take in the child: the smaller one for both)
    r = min(r_behind, r_ahead)
    step = max(SECTION_STEP_R * r, SECTION_STEP_MIN_PX)
    k = step * np.arange(SECTIONS)
    s = np.concatenate([-(max(0.0, (r_child - r * cos_a) / sin_a) + 0.5 * r + 3.0 + k),
                        (r * cos_a + r_child) / sin_a + 0.5 * r + 3.0 + k])
    mids = section_middles(mask, np.asarray(xy, float), e, n, s, r)
    if len(mids) < 3:
        return None
    c, ea = _tls(mids)
    res = np.abs((mids - c) @ np.array([-ea[1], ea[0]]))
    if (res > MIDDLE_OFF_PX).any() and (res <= MIDDLE_OFF_PX).sum() >= 3:     # (off middles: left out once)
        c, ea = _tls(mids[res <= MIDDLE_OFF_PX])
    return (c, ea) if abs(ea[0] * e[1] - ea[1] * e[0]) <= MAX_TURN_SIN else None
