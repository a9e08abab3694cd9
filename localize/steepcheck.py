"""Short steep pieces checked against the right-view run they were matched to, by their bark texture.

A steep piece is matched row by row to a right-view run of similar width on the straight line
(u, v, d) through most candidates (:func:`dense.fit_steep_many`). Over a few rows that line is not
unique: a narrow strip of a branch can fit another branch's run of the same width (seed 118: a
13-row piece of a trunk matched to a twig 20 px of disparity away, ~250 mm off). The outline says
nothing more there, but the bark does: the same surface seen from both cameras correlates
strongly (normalised cross-correlation ~0.9 at the surface's disparity), another branch's bark
does not (~0). A short piece whose texture does not correlate at its own fitted disparity while it
clearly correlates elsewhere in the working range shows another surface in its run: it is not
reported rather than reported at a confident wrong depth (:func:`withheld_segments`), nor matched
again edge by edge.
Measured on 60 scenes: docs/localize-steepcheck.md.

The surface a patch sees is nearer than the axis (up to one radius): the piece's own disparity is
searched from its curve's (axis) disparity to that of a surface one radius nearer, +-``SLACK_PX``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from appliance.localize import kernels_ncc
from appliance.localize.curves import BranchCurve
from appliance.localize.matching import StereoMasks

MAX_ROWS = 25          # pieces whose fitted span is at most this many rows are checked
STEP_ROWS = 3          # one patch every this many rows
HALF_H_PX = 3          # patch half height (7 rows)
SLACK_PX = 1.5         # own window: axis disparity - slack .. one-radius-nearer surface's + slack
OWN_MAX = 0.6          # median correlation at the own run below this: the run shows another surface
OWN_CLEAR = 0.2        # below this the range search is skipped (60 scenes: such pieces' best was >= 0.73)
MARGIN = 0.2           # ... and the best correlation in the working range is at least this much higher
MIN_ROWS = 4           # a shorter piece (a stub between junctions): its patches lie mostly outside it
MIN_PATCHES = 2        # fewer patches with texture say too little: not judged


@dataclass(frozen=True)
class TextureCheck:
    """One short steep piece's texture test.

    Attributes
    ----------
    segment : int
    n_patches : int
        Patches with texture inside both views.
    own : float
        Median over the patches of the best correlation in the piece's own disparity window.
    other : float
        Median of the best correlation over the whole working range (NaN when not searched: ``own``
        was high enough).
    withheld : bool
    """

    segment: int
    n_patches: int
    own: float
    other: float
    withheld: bool


def _median(a: np.ndarray) -> float:
    """The median of a few values (np.median's checks cost more here)."""
    v = sorted(a.tolist())
    k = len(v) // 2
    return v[k] if len(v) % 2 else 0.5 * (v[k - 1] + v[k])


def _half_w(radius_px: float) -> int:
    """Patch half width: inside the branch's visible width (0.6 radius), 2-7 px."""
    return int(min(7, max(2, round(0.6 * radius_px))))


def _patches(c: BranchCurve, f_px: float, shape: tuple[int, int]) -> tuple[list, list, list, list]:
    """Patch centres (u, v) int every ``STEP_ROWS`` rows along a steep curve and each one's own window
    (lo, hi) int disparities, as lists (a few patches: Python floats cost less than arrays here);
    patches whose own strips leave the image are dropped."""
    h, w = shape
    t0, t1 = c.t_range
    hw, hh = _half_w(c.radius_px), HALF_H_PX
    nearer = 1.0 / max(1.0 - c.radius_px / f_px, 0.5)     # axis -> surface one radius nearer
    us, vs, los, his = [], [], [], []
    for v in range(math.ceil(t0), math.floor(t1) + 1, STEP_ROWS):
        u = round(c.s_poly.at(v))
        d = c.d_poly.at(v)
        lo, hi = math.floor(d - SLACK_PX), math.ceil(d * nearer + SLACK_PX)
        if hh <= v < h - hh and u - hi - hw >= 0 and u - lo + hw < w and hw <= u < w - hw:
            us.append(u), vs.append(v), los.append(lo), his.append(hi)
    return us, vs, los, his


def _scores(left, right, us: list, vs: list, los: list, his: list, hw: int) -> np.ndarray:
    """Best normalised correlation (P,) of each patch (centres ``us``, ``vs`` int, half width ``hw``, half
    height ``HALF_H_PX``) over its disparities ``los``..``his`` int (:func:`kernels_ncc.ncc_search`: the
    same scores as matchTemplate's TM_CCOEFF_NORMED; strips clipped at the image's edge); -1 for a patch
    without texture (std < 1 grey level). The images are read once each, over the box the patches and
    their strips need."""
    h, w = left.shape
    hh = HALF_H_PX
    y0, y1 = min(vs) - hh, max(vs) + hh + 1
    lx0, lx1 = min(us) - hw, max(us) + hw + 1
    rx0 = max(min(u - d for u, d in zip(us, his)) - hw, 0)
    rx1 = min(max(u - d for u, d in zip(us, los)) + hw + 1, w)
    lbox = np.ascontiguousarray(left[y0:y1, lx0:lx1])
    rbox = np.ascontiguousarray(right[y0:y1, rx0:rx1])
    n = len(us)
    hhs, score, d_out = np.empty(n, np.int64), np.empty(n), np.empty(n)     # (np.full's values, without its wrapper)
    hhs.fill(hh)
    score.fill(-1.0)
    d_out.fill(np.nan)
    uv = np.array([us, vs], np.int64).T.copy()
    lo0, hi0 = min(los), max(his)
    if max(los) - lo0 <= 1 and hi0 - min(his) <= 1:     # (nearly) one window for all: one call, over their union
        kernels_ncc.ncc_search(lbox, rbox, uv, hhs, hw, lo0, hi0, h, w, y0, lx0, rx0, d_out, score)
        return score
    for i in range(n):                       # (a few patches, each with its own window)
        kernels_ncc.ncc_search(lbox, rbox, uv[i:i + 1], hhs[:1], hw, los[i], his[i], h, w, y0, lx0, rx0,
                           d_out[i:i + 1], score[i:i + 1])
    return score


def check_piece(c: BranchCurve, sm: StereoMasks, max_rows: float = MAX_ROWS) -> TextureCheck | None:
    """The texture test of one steep curve (None: not a steep piece of ``MIN_ROWS`` to ``max_rows``
    rows of fitted span, or fewer than ``MIN_PATCHES`` patches with texture)."""
    if not c.by_row or not MIN_ROWS <= c.t_range[1] - c.t_range[0] <= max_rows:
        return None
    us, vs, los, his = _patches(c, sm.f_px, sm.left_mask.shape)
    if len(us) < MIN_PATCHES:
        return None
    hw = _half_w(c.radius_px)
    own = _scores(sm.left_gray, sm.right_gray, us, vs, los, his, hw)
    textured = own > -1.0
    n = int(textured.sum())
    if n < MIN_PATCHES:
        return None
    own = own[textured]
    own_med = _median(own)
    if own_med >= OWN_MAX:
        return TextureCheck(int(c.segment), n, own_med, float("nan"), False)
    if own_med < OWN_CLEAR:             # another surface beyond doubt: the range search would confirm it
        return TextureCheck(int(c.segment), n, own_med, float("nan"), True)
    keep = np.flatnonzero(textured).tolist()
    us, vs = [us[i] for i in keep], [vs[i] for i in keep]
    d_lo, d_hi = math.floor(sm.d_range_px[0]), math.ceil(sm.d_range_px[1])
    other = _scores(sm.left_gray, sm.right_gray, us, vs, [d_lo] * n, [d_hi] * n, hw)
    other_med = _median(np.maximum(other, own))
    return TextureCheck(int(c.segment), n, own_med, other_med, other_med - own_med >= MARGIN)


def wrong_run_pieces(curves: dict[int, BranchCurve], sm: StereoMasks) -> list[TextureCheck]:
    """Every short steep piece's texture test (:func:`check_piece`), in segment order."""
    out = []
    for s in sorted(curves):
        r = check_piece(curves[s], sm)
        if r is not None:
            out.append(r)
    return out


def withheld_segments(curves: dict[int, BranchCurve], sm: StereoMasks) -> set[int]:
    """The segments of the short steep pieces whose curves are not to be reported (:func:`check_piece`)."""
    return {r.segment for r in wrong_run_pieces(curves, sm) if r.withheld}

