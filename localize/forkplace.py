"""The parent's axis at a fork from its own outline (where the fork is placed, issue 5).

Near a crotch the parent's centre line (skeleton or fitted row middles) is pulled towards the
child: the child widens the silhouette on its side from where its back edge leaves the parent's
outline to where its front edge does. Cross-sections of the parent square to its axis, taken on
both sides of the fork outside that stretch, cross the parent alone; the middles of those whose
width is the parent's own lie on its axis (its two edges are parallel).
"""

from __future__ import annotations

import cv2
import numpy as np

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
    c = pts.mean(0)
    q = pts - c
    sxx, syy, sxy = float(q[:, 0] @ q[:, 0]), float(q[:, 1] @ q[:, 1]), float(q[:, 0] @ q[:, 1])
    ang = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    return c, np.array([np.cos(ang), np.sin(ang)])


def _sample(mask: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``mask`` (H, W) uint8 at points ``uv`` (N, 2) (x, y), bilinear; 0 outside the image."""
    m = uv.astype(np.float32).reshape(1, -1, 2)
    return cv2.remap(mask, m, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)[0]


def section_middles(mask: np.ndarray, base: np.ndarray, e: np.ndarray, n: np.ndarray, s: np.ndarray,
                    r_px: np.ndarray) -> np.ndarray:
    """Middles (M, 2) of the parent's cross-sections at ``base + s_k e`` (``s`` (K,), px) along ``n``.

    Each section is read on ``t`` in +-(2.5 r + 4) px, 1 px apart; its run of coverage >= 128
    through (or nearest within ``MIDDLE_MAX_R`` r of) ``t = 0``, ends interpolated at 128, is kept
    when its width is the parent's ``2 r_px[k]`` within ``WIDTH_TOL`` (and ``WIDTH_TOL_PX``) and the
    sections' median width within ``SAME_WIDTH`` (and ``SAME_WIDTH_PX``).
    """
    if len(s) == 0:
        return np.zeros((0, 2))
    half = int(np.ceil(2.5 * float(np.max(r_px)) + 4.0))
    t = np.arange(-half, half + 1, dtype=float)
    pts = base + s[:, None, None] * e + t[None, :, None] * n          # (K, T, 2)
    val = _sample(mask, pts.reshape(-1, 2)).reshape(len(s), len(t)).astype(float)
    on = val >= 128.0
    out = []
    for k in range(len(s)):
        r = float(r_px[k])
        near = np.flatnonzero(on[k] & (np.abs(t) <= MIDDLE_MAX_R * r + 1.0))
        if len(near) == 0:
            continue
        c = int(near[np.argmin(np.abs(t[near]))])
        off_lo = np.flatnonzero(~on[k, :c])
        off_hi = np.flatnonzero(~on[k, c:])
        if len(off_lo) == 0 or len(off_hi) == 0:           # the section runs off its window
            continue
        a, b = int(off_lo[-1]), c + int(off_hi[0])           # the last off before, the first off after
        va, vb = val[k, a], val[k, b]
        lo = t[a] + (128.0 - va) / max(val[k, a + 1] - va, 1e-9)
        hi = t[b] - (128.0 - vb) / max(val[k, b - 1] - vb, 1e-9)
        if abs((hi - lo) - 2.0 * r) > WIDTH_TOL * 2.0 * r + WIDTH_TOL_PX:
            continue
        mid = 0.5 * (lo + hi)
        if abs(mid) > MIDDLE_MAX_R * r + 1.0:
            continue
        out.append((*(base + s[k] * e + mid * n), hi - lo))
    out = np.array(out).reshape(-1, 3)
    if len(out):       # the parent's own width is the sections' usual one: a wider or narrower one is merged
        w = float(np.median(out[:, 2]))
        out = out[np.abs(out[:, 2] - w) <= SAME_WIDTH * w + SAME_WIDTH_PX]
    return out[:, :2]


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
    mids = section_middles(mask, np.asarray(xy, float), e, n, s, np.full(len(s), r))
    if len(mids) < 3:
        return None
    c, ea = _tls(mids)
    res = np.abs((mids - c) @ np.array([-ea[1], ea[0]]))
    if (res > MIDDLE_OFF_PX).any() and (res <= MIDDLE_OFF_PX).sum() >= 3:     # (off middles: left out once)
        c, ea = _tls(mids[res <= MIDDLE_OFF_PX])
    return (c, ea) if abs(ea[0] * e[1] - ea[1] * e[0]) <= MAX_TURN_SIN else None
