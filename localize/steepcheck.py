"""Short steep pieces checked against the right-view run they were matched to, by their bark texture.

A steep piece is matched row by row to a right-view run of similar width on the straight line
(u, v, d) through most candidates (:func:`dense.fit_steep_many`). Over a few rows that line is not
unique: a narrow strip of a branch can fit another branch's run of the same width (seed 118: a
13-row piece of a trunk matched to a twig 20 px of disparity away, ~250 mm off). The outline says
nothing more there, but the bark does: the same surface seen from both cameras correlates
strongly (normalised cross-correlation ~0.9 at the surface's disparity), another branch's bark
does not (~0). A short piece whose texture does not correlate at its own fitted disparity while it
clearly correlates elsewhere in the working range shows another surface in its run: it gets no
curve rather than a confident wrong depth.

The surface a patch sees is nearer than the axis (up to one radius): the piece's own disparity is
searched from its curve's (axis) disparity to that of a surface one radius nearer, +-``SLACK_PX``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from appliance.localize import kernels
from appliance.localize.curves import BranchCurve
from appliance.localize.matching import StereoMasks
from appliance.localize.texture import _ncc_core, _windows

MAX_ROWS = 25          # pieces whose fitted span is at most this many rows are checked
STEP_ROWS = 3          # one patch every this many rows
HALF_H_PX = 3          # patch half height (7 rows)
SLACK_PX = 1.5         # own window: axis disparity - slack .. one-radius-nearer surface's + slack
OWN_MAX = 0.45         # median correlation at the own run below this: the run shows another surface
MARGIN = 0.2           # ... and the best correlation in the working range is at least this much higher
SAME_RUN_PX = 3.0      # a withheld piece matched again within this of its old disparity: the same run
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


def _half_w(radius_px: float) -> int:
    """Patch half width: inside the branch's visible width (0.6 radius), 2-7 px."""
    return int(min(7, max(2, round(0.6 * radius_px))))


def _patches(c: BranchCurve, f_px: float, shape: tuple[int, int], d_range_px: tuple[float, float]):
    """Patch centres (P, 2) int (u, v) along a steep curve and each one's own window (lo, hi) int
    disparities; patches whose own or whole-range strips leave the image are dropped."""
    h, w = shape
    t0, t1 = c.t_range
    a, b = int(np.ceil(t0)), int(np.floor(t1))
    if b < a:
        return np.zeros((0, 2), int), np.zeros(0, int), np.zeros(0, int)
    n = max(1, (b - a) // STEP_ROWS + 1)
    v = np.rint(np.linspace(a, b, n) if n > 1 else np.array([0.5 * (a + b)])).astype(int)
    u = np.rint(c.s_poly(v.astype(float))).astype(int)
    d = np.asarray(c.d_poly(v.astype(float)), float)
    lo = np.floor(d - SLACK_PX).astype(int)
    hi = np.ceil(d / max(1.0 - c.radius_px / f_px, 0.5) + SLACK_PX).astype(int)
    hw, hh = _half_w(c.radius_px), HALF_H_PX
    dmin = int(np.floor(d_range_px[0]))
    ok = (v - hh >= 0) & (v + hh < h) & (u - hw >= 0) & (u + hw < w) & (u - hi - hw >= 0) & (u - lo + hw < w) \
        & (u - dmin + hw + 1 > 0)
    return np.column_stack([u, v])[ok], lo[ok], hi[ok]


def _own_scores(left, right, uv: np.ndarray, lo: np.ndarray, hi: np.ndarray, hw: int) -> tuple[np.ndarray, np.ndarray]:
    """Best correlation (P,) of each patch in its own window, and whether it has texture (P,) bool."""
    hh = HALF_H_PX
    n_pos = int((hi - lo).max()) + 1
    y0, y1 = int(uv[:, 1].min()) - hh, int(uv[:, 1].max()) + hh + 1
    lx0, lx1 = int(uv[:, 0].min()) - hw, int(uv[:, 0].max()) + hw + 1
    rx0 = int((uv[:, 0] - hi).min()) - hw
    rx1 = max(int((uv[:, 0] - hi).max()) + n_pos + hw, int((uv[:, 0] - lo).max()) + hw + 1)
    lbox = np.asarray(left[y0:y1, lx0:lx1])
    rbox = np.asarray(right[y0:y1, rx0:min(rx1, right.shape[1])])
    if rbox.shape[1] < rx1 - rx0:                      # (the longest window past the image's edge)
        rbox = np.pad(rbox, ((0, 0), (0, rx1 - rx0 - rbox.shape[1])), mode="edge")
    ty = uv[:, 1] - hh - y0
    tmpl = _windows(lbox, (2 * hh + 1, 2 * hw + 1))[ty, uv[:, 0] - hw - lx0].astype(np.float64)
    strip = _windows(rbox, (2 * hh + 1, n_pos + 2 * hw))[ty, uv[:, 0] - hi - hw - rx0].astype(np.float64)
    _, best, flat = _ncc_core(tmpl, strip, uv, hh, hw, n_pos, hi)
    return best, ~flat


def _range_scores(left, right, uv: np.ndarray, hw: int, d_range_px: tuple[float, float]) -> np.ndarray:
    """Best correlation (P,) of each patch over the whole working range (-1 where not searched)."""
    h, w = left.shape
    hh = HALF_H_PX
    lo, hi = int(np.floor(d_range_px[0])), int(np.ceil(d_range_px[1]))
    y0, y1 = max(int(uv[:, 1].min()) - hh, 0), min(int(uv[:, 1].max()) + hh + 1, h)
    lx0, lx1 = max(int(uv[:, 0].min()) - hw, 0), min(int(uv[:, 0].max()) + hw + 1, w)
    rx0, rx1 = max(int(uv[:, 0].min()) - hi - hw, 0), min(int(uv[:, 0].max()) - lo + hw + 1, w)
    lbox = np.require(np.asarray(left[y0:y1, lx0:lx1]), np.uint8, ["C", "W"])
    rbox = np.require(np.asarray(right[y0:y1, rx0:rx1]), np.uint8, ["C", "W"])
    d_out, score = np.full(len(uv), np.nan), np.full(len(uv), -1.0)
    kernels.ncc_search(lbox, rbox, np.ascontiguousarray(uv, np.int64), np.full(len(uv), hh, np.int64), hw,
                       lo, hi, h, w, y0, lx0, rx0, d_out, score)
    return score


def check_piece(c: BranchCurve, sm: StereoMasks, max_rows: float = MAX_ROWS) -> TextureCheck | None:
    """The texture test of one steep curve (None: not a steep piece of at most ``max_rows`` rows of
    fitted span, or too few patches)."""
    if not c.by_row or not MIN_ROWS <= c.t_range[1] - c.t_range[0] <= max_rows:
        return None
    uv, lo, hi = _patches(c, sm.f_px, sm.left_mask.shape, sm.d_range_px)
    if len(uv) < MIN_PATCHES:
        return None
    hw = _half_w(c.radius_px)
    own, textured = _own_scores(sm.left_gray, sm.right_gray, uv, lo, hi, hw)
    if textured.sum() < MIN_PATCHES:
        return None
    uv, own = uv[textured], own[textured]
    own_med = float(np.median(own))
    if own_med >= OWN_MAX:
        return TextureCheck(int(c.segment), len(uv), own_med, float("nan"), False)
    other = _range_scores(sm.left_gray, sm.right_gray, uv, hw, sm.d_range_px)
    other_med = float(np.median(np.maximum(other, own)))
    return TextureCheck(int(c.segment), len(uv), own_med, other_med, other_med - own_med >= MARGIN)


def wrong_run_pieces(curves: dict[int, BranchCurve], sm: StereoMasks) -> list[TextureCheck]:
    """Every short steep piece's texture test (:func:`check_piece`); the caller drops the curves of
    those ``withheld``."""
    out = []
    for s in sorted(curves):
        r = check_piece(curves[s], sm)
        if r is not None:
            out.append(r)
    return out


def withheld_segments(curves: dict[int, BranchCurve], sm: StereoMasks) -> dict[int, BranchCurve]:
    """The short steep pieces whose curves are not to be reported (:func:`check_piece`): {segment: curve}."""
    return {r.segment: curves[r.segment] for r in wrong_run_pieces(curves, sm) if r.withheld}


def confirmed(new_curves: dict[int, BranchCurve], withheld: dict[int, BranchCurve],
              sm: StereoMasks) -> dict[int, BranchCurve]:
    """``new_curves`` (a later stage's curves of pieces without one, e.g. matched edge by edge) without
    those of the ``withheld`` pieces that come back on the run their texture refused (within
    ``SAME_RUN_PX`` of the withheld curve's disparity on its rows, median) or whose texture does not
    confirm the new curve (:func:`check_piece`, whatever its length)."""
    out = {}
    for s, c in new_curves.items():
        old = withheld.get(s)
        if old is not None:
            lo, hi = old.t_range
            t = np.arange(np.ceil(lo), np.floor(hi) + 1) if hi >= lo + 1 else np.array([0.5 * (lo + hi)])
            if np.median(np.abs(c.d_at(t) - old.d_poly(t))) <= SAME_RUN_PX:
                continue
            r = check_piece(c, sm, max_rows=np.inf)
            if r is None or r.withheld:
                continue
        out[s] = c
    return out
