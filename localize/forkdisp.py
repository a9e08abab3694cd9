"""A fork's parent disparity from the parent's own crossings nearest the fork (improved variant).

A parent piece's fit leaves out its rows near the junction (the crotch's blob, 1.6 radii around the
skeleton junction, where the child widens the silhouette) and is carried to the fork along the
slope fitted to its last samples, sometimes 30-100 rows, often off by 0.5-1.5 px there. Most of
those rows still cross the parent alone, as wide as the piece's last fitted rows in both views,
and their disparities are as good as the fitted ones: a straight line through them and the
span's rows next to its end, read at the fork's row, is that side's disparity at the fork.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from appliance.localize import kernels_forknear, kernels_forks
from appliance.localize.curves import BranchCurve, median
from appliance.localize.edges import Runs
from appliance.localize.patchmask import share_difference
from appliance.localize.texture import surface_to_axis


# a parent side's fit carried at least this far (px of its parameter) to the fork is read again from its
# own crossings nearest the fork; rows of the span next to its end taken with them
SIDE_GAP_MIN_PX = 6.0
SIDE_SPAN_ROWS = 40
# the two views' row crossings compared at their own slopes (``_carried``)
SIDE_WIDTH_SLOPE = True
# ... and at their own distances from each view's principal point (``perspective_width_ratio``): a thick
# branch off the image's middle is crossed 2-3 % narrower in the view it lies nearer the middle of (seed
# 375's fork: a 62.6 px left crossing 60.5 px in the right view, every row failing the 1.2 px check)
SIDE_WIDTH_PERSPECTIVE = True
# a read whose rows stop more than SIDE_GROWN_SHORT_PX short of the fork is read again with the crotch's rows
# (within SIDE_GROWN_MAX_W span widths of the fork's) whose left crossing is wider than the span's (beyond
# 10 % + 1.5 px) by up to SIDE_GROWN_FRAC of its width plus SIDE_GROWN_PX, where the right crossing is as much
# wider (within SIDE_GROWN_TOL_PX): there the child's pixels join the parent's outline on one side at the
# parent's depth in both views, their middles moved alike. The width check alone drops 70 % of the rows within
# two radii of the fork on the child's side, and a read that stops short is carried by its line: p95 0.58 px
# against 0.34 px for reads reaching the fork (docs/localize-forktail23.md)
SIDE_GROWN_SHORT_PX = 6.0
SIDE_GROWN_MIN_ROWS = 3             # (the second read taken where it keeps this many rows more: one or two rows at
                                    # the line's end move its value at the fork by their own noise, 0.5 px there)
SIDE_GROWN_FRAC = 0.2
SIDE_GROWN_PX = 2.5
SIDE_GROWN_TOL_PX = 0.6
SIDE_GROWN_MAX_W = 0.5
# A read whose only row between the span and the fork is one crossing far from the span (LONE_GAP_ROW_MIN_PX
# rows or more) is a line pivoted on that one row: carried from the span to the fork through it, its value is
# that crossing's own error magnified (772 T9, colour masks: a right crossing the merging outline widened by
# 1.1 px, still within the width check while its neighbours failed it, -1.12 px at the fork; its curve +1.26).
# Such a read is replaced by the line through the span's rows alone, read at the fork (:func:`rests_on_lone_gap_row`,
# :func:`span_rows_read`): a read still, carried from the span (the rules that weigh a read by its reach see it so).
LONE_GAP_ROW_UNREAD = True
LONE_GAP_ROW_MIN_PX = 6.0
# A side inclined steeply in depth (its read line's disparity slope, px per row, times f / (d - offset): how many mm
# its depth changes per mm along its rows, at least SIDE_TURN_MIN_INCLINE) is read again with only the span's
# SIDE_TURN_SPAN_ROWS rows next to its end: the line's slope from the span's far rows is off by 10-20 % on such a
# side (1033's parent: 0.18 px/row read, 0.15 true; 980's: 0.146, 0.178 true), and carried over the span's half and
# the gap to the fork that is 0.5-0.9 px (1033 T11, 980 T13). Measured on 1.56-1.80 (1033 T11, 980 T13, 999 T9, 564
# T7, 643 T9, 153 T7); the sides at 0.9-1.35 (614 T9, 675 T9, 681 T7, 146 T7, 147 T11, at 725-950 mm) moved as many
# forks the wrong way as the right one with the shorter line (docs/localize-gross30.md)
SIDE_TURN_SHORT = True
SIDE_TURN_MIN_INCLINE = 1.45
SIDE_TURN_SPAN_ROWS = 20
# ... and read first with a parabola in the row through the span's SIDE_SPAN_ROWS rows (and the gap's), where it
# keeps SIDE_TURN_QUAD_MIN_ROWS rows (else the 20-row line): what such a side's line is off by is mostly the parent's
# own bend in depth, not its crossings. 980 T13's parent (exact masks): the line through the true disparities on the
# read's own rows is +0.83 px off at the fork over 40 rows, +0.37 over 20 (its 30 mm pieces cross 12-17 rows each,
# their slopes 0.174, 0.189, 0.132, 0.129 px/row from the fork on), the crossings' own error +0.06 / +0.42; a side
# turning by a given angle changes its disparity slope (1 + k^2) times more at k mm of depth per mm along its rows.
# The parabola: 980 T13 -5.09 -> -3.78 mm (colour -1.54 -> -1.27), 999 T9 colour -1.18 -> -0.94, 564 T7 -1.72 ->
# -1.67 / +4.22 -> +3.93 (docs/localize-turn31.md)
SIDE_TURN_QUAD = True
SIDE_TURN_QUAD_MIN_ROWS = 20


def side_disparity_near(c: BranchCurve, runs_l: Runs, runs_r: Runs, t_fork: float, gap_min_px: float = SIDE_GAP_MIN_PX,
                        span_rows: int = SIDE_SPAN_ROWS, tol_d_px: float = 2.5, width_tol_px: float = 1.2,
                        min_rows: int = 12, max_gap_px: int = 300, f_px: float | None = None,
                        cx_px: float | None = None, offset_px: float = 0.0, past_rows: int = 0) -> SideNear | None:
    """A steep parent side's disparity at a fork from its own crossings nearest the fork.

    A piece's fit leaves out the rows near its junction (the crotch's blob) and is carried to the
    fork along its end slope, sometimes 30-100 rows. Many of those rows still cross the parent alone:
    their left crossing is as wide as the piece's last fitted rows and centred on its line, and a
    right crossing as wide lies at the carried disparity (within ``tol_d_px``). A straight line
    (robust) through those rows and the span's ``span_rows`` rows next to its end, read at the
    fork's row, is the side's disparity there.

    Parameters
    ----------
    c : BranchCurve
        The side's curve (by row; a flat one gives None).
    runs_l, runs_r : Runs
        Both views' row crossings.
    t_fork : float
        The fork's row.
    f_px, cx_px, offset_px : float, optional
        The rectified focal length, the left view's principal-point column and ``cx_left - cx_right``:
        the right crossing's width is expected at :func:`perspective_width_ratio` times the left's
        (``SIDE_WIDTH_PERSPECTIVE``; without ``f_px`` and ``cx_px``, at the slopes' ratio alone).
    past_rows : int, optional
        Rows past the fork (on the far side from the span) read too, along the same carried tangent: where the
        parent runs on past the fork, its crossings there put the fork between the line's rows
        (:func:`side_through_fork`); 0: the rows from the fork to the span only.

    Returns
    -------
    SideNear or None
        None when the fork lies within ``gap_min_px`` of the span (the fit is read there) or further
        than ``max_gap_px`` from it, or fewer than ``min_rows`` rows are found. A side inclined in depth by
        ``SIDE_TURN_MIN_INCLINE`` mm per mm or more (its line's slope times ``f_px / (d - offset_px)``; with
        ``f_px`` given) is read again with a parabola through the same rows (``SIDE_TURN_QUAD``, where it keeps
        ``SIDE_TURN_QUAD_MIN_ROWS``), else with ``SIDE_TURN_SPAN_ROWS`` span rows (``SIDE_TURN_SHORT``).
    """
    kw = dict(gap_min_px=gap_min_px, tol_d_px=tol_d_px, width_tol_px=width_tol_px, min_rows=min_rows,
              max_gap_px=max_gap_px, f_px=f_px, cx_px=cx_px, offset_px=offset_px, past_rows=past_rows)
    v = _side_read(c, runs_l, runs_r, t_fork, span_rows, **kw)
    if SIDE_TURN_SHORT and v is not None and span_rows > SIDE_TURN_SPAN_ROWS and f_px is not None \
            and abs(v.slope) * f_px >= SIDE_TURN_MIN_INCLINE * max(v.d_px - offset_px, 1.0):
        # (a side turning fast in depth: its line's slope from the span's far rows carried to the fork is off)
        if SIDE_TURN_QUAD:
            w = _side_read(c, runs_l, runs_r, t_fork, span_rows, deg=2, **kw)
            if w is not None and w.n_rows >= SIDE_TURN_QUAD_MIN_ROWS:
                return w
        w = _side_read(c, runs_l, runs_r, t_fork, SIDE_TURN_SPAN_ROWS, **kw)
        if w is not None:
            return w
    return v


def _side_read(c: BranchCurve, runs_l: Runs, runs_r: Runs, t_fork: float, span_rows: int, gap_min_px: float,
               tol_d_px: float, width_tol_px: float, min_rows: int, max_gap_px: int, f_px: float | None,
               cx_px: float | None, offset_px: float, past_rows: int, deg: int = 1) -> SideNear | None:
    """One read of :func:`side_disparity_near` with the span's ``span_rows`` rows (its arguments, px); ``deg`` 2:
    a parabola through the rows instead of a line."""
    if not c.by_row or not math.isfinite(t_fork):
        return None
    lo, hi = c.t_range
    if lo - gap_min_px < t_fork < hi + gap_min_px:
        return None
    end, sg = (lo, 1.0) if t_fork < lo else (hi, -1.0)
    n_gap = int(abs(t_fork - end))
    if n_gap > max_gap_px:
        return None
    # the rows from the fork's to span_rows into the span (the first 20 of those also give the width),
    # the crossings, the checks and the line compiled (kernels_forks.side_near)
    s_end, slope_s, d_end, slope_d, ratio = _carried(c, end)
    if SIDE_WIDTH_PERSPECTIVE and f_px is not None and cx_px is not None:
        ratio *= perspective_width_ratio(s_end, d_end, f_px, cx_px, offset_px)
    tl, tr = runs_l._find_tables, runs_r._find_tables
    views = (*tl, runs_l.width, runs_l.span_px, runs_l.centre_px, *tr, runs_r.width, runs_r.span_px, runs_r.centre_px)
    line = (int(span_rows), sg, float(end), s_end, slope_s, d_end, slope_d, ratio, float(t_fork),
            float(tol_d_px), float(width_tol_px), int(min_rows), 3.5)
    args = (*views, n_gap + int(past_rows), *line)
    ok, d, n_rows, n_gap_k, nearest, mad, slope = kernels_forks.side_near(*args, 0.0, 0.0, 0.0, 0.0, deg)
    if ok and nearest > SIDE_GROWN_SHORT_PX:     # (stops short of the fork: the crotch's widened rows with them)
        grown = kernels_forks.side_near(*args, float(SIDE_GROWN_FRAC), float(SIDE_GROWN_PX), float(SIDE_GROWN_TOL_PX),
                                        float(SIDE_GROWN_MAX_W), deg)
        if grown[0] and grown[2] >= n_rows + SIDE_GROWN_MIN_ROWS:
            ok, d, n_rows, n_gap_k, nearest, mad, slope = grown
    if not ok or (n_gap_k == 0 and hi - lo < 2 * span_rows):
        # (no row past the span: a short span's fit is already a line through these rows)
        return None
    v = SideNear(d, n_rows, n_gap_k, n_gap, nearest, mad, slope)
    if LONE_GAP_ROW_UNREAD and not past_rows and rests_on_lone_gap_row(v):
        return span_rows_read(views, line, n_gap, deg)
    return v


# a lone steep parent side whose read stops short of the fork (or that is carried there unread) is read again with
# the parent's crossings past the fork, on the far side from its span, as far as the other parent piece (without a
# curve through the fork) reaches, at most THROUGH_MAX_ROWS: the fork then lies between the line's rows (seed 620
# T1: a trunk side read 33 rows short, +0.63 px; docs/localize-forkp27.md)
THROUGH_MAX_ROWS = 40
THROUGH_SHORT_PX = 6.0


def side_through_fork(c: BranchCurve, runs_l: Runs, runs_r: Runs, t_fork: float, past_rows: float,
                      height_px: int, **kw) -> SideNear | None:
    """A steep parent side read through the fork: :func:`side_disparity_near` with the parent's crossings up to
    ``past_rows`` rows past the fork (at most ``THROUGH_MAX_ROWS``, inside the image's ``height_px`` rows) read
    with those between the fork and the span, along the span's carried tangent.

    Parameters
    ----------
    c : BranchCurve
        The side's curve (steep; a flat one gives None).
    runs_l, runs_r : Runs
        Both views' row crossings.
    t_fork : float
        The fork's row.
    past_rows : float
        How far (rows) the parent runs on past the fork in the image (the other parent piece's reach).
    height_px : int
        The image's height (rows past it are not read).
    **kw
        :func:`side_disparity_near`'s other arguments (``f_px``, ``cx_px``, ``offset_px``).

    Returns
    -------
    SideNear or None
        The read (its ``nearest_px`` the kept row nearest the fork on either side), or None (as
        :func:`side_disparity_near`; no row past the fork to read).
    """
    if not c.by_row or not math.isfinite(t_fork):
        return None
    lo, _ = c.t_range
    # (the rows past the fork run away from the span: up the image when the span lies below the fork)
    room = int(t_fork) if t_fork < lo else int(height_px - 1 - math.ceil(t_fork))
    past = int(min(past_rows, THROUGH_MAX_ROWS, max(room - 1, 0)))
    if past <= 0:
        return None
    return side_disparity_near(c, runs_l, runs_r, t_fork, past_rows=past, **kw)


def span_rows_read(views: tuple, line: tuple, n_gap: int, deg: int = 1) -> SideNear | None:
    """The read of :func:`side_disparity_near` from the span's rows alone (no row between the span and the
    fork: ``kernels_forks.side_near`` with no gap), read at the fork's row: what a read resting on a lone gap
    row (:func:`rests_on_lone_gap_row`) is replaced by. ``views``: both views' runs as the kernel takes them;
    ``line``: the kernel's arguments after ``n_gap``; ``n_gap``: the rows between the span and the fork. None
    where too few of the span's rows are kept."""
    ok, d, n_rows, _, nearest, mad, slope = kernels_forks.side_near(*views, 0, *line, 0.0, 0.0, 0.0, 0.0, deg)
    return SideNear(d, n_rows, 0, n_gap, nearest, mad, slope) if ok else None


def rests_on_lone_gap_row(v: "SideNear", min_px: float = LONE_GAP_ROW_MIN_PX) -> bool:
    """Whether a side read's line is pivoted on one crossing: its only row between the span and the fork lies
    ``min_px`` rows or more from the span's end (``LONE_GAP_ROW_UNREAD``).

    Parameters
    ----------
    v : SideNear
        A read of :func:`side_disparity_near`.
    min_px : float
        Rows between the lone gap row and the span's end from which the row alone sets the line's carry.

    Returns
    -------
    bool
    """
    return v.n_gap_rows == 1 and v.gap_px - v.nearest_px >= min_px


def perspective_width_ratio(u_px: float, d_px: float, f_px: float, cx_px: float, offset_px: float = 0.0) -> float:
    """The right view's row crossing width of a branch over the left's, from their columns alone.

    A cylinder of radius R at depth Z whose centre line is seen at ``x`` px from the principal point is
    crossed along the row over ``2 R f sqrt(1 + (x / f)^2) / Z`` (its angular width ``2 R / rho``, the
    image stretched by ``sec^2`` of the ray's angle; ``rho = Z sqrt(1 + (x / f)^2)``); the two views see
    it at the same Z, at ``x_l = u - cx`` and ``x_r = u - d - (cx - offset)``.

    Parameters
    ----------
    u_px, d_px : float
        The left view's column of the centre line and its disparity (px).
    f_px, cx_px, offset_px : float
        Rectified focal length, the left principal point's column, ``cx_left - cx_right`` (px).
    """
    x_l = u_px - cx_px
    x_r = x_l - (d_px - offset_px)
    return math.hypot(f_px, x_r) / math.hypot(f_px, x_l)


def line_carry_var(n_rows: float, gap_rows: float) -> float:
    """Variance (in units of one row's) of a least-squares line through ``n_rows`` consecutive rows
    read ``gap_rows`` past the last of them: 1 / n + 12 (g + n / 2)^2 / n^3 (the rows' mean is
    n / 2 from their end, their spread n^3 / 12)."""
    n = max(float(n_rows), 2.0)
    return 1.0 / n + 12.0 * (gap_rows + 0.5 * n) ** 2 / n ** 3


def weigh_sides(d_px, rows) -> float:
    """A fork's disparity from its two parent sides' values ``d_px`` (2,) that disagree beyond their
    rows' noise: their mean weighted by how well each is known at the fork, the inverse of
    :func:`line_carry_var` of its (rows, rows carried) in ``rows`` ((n, g) per side: a side fitted
    on a few rows, or carried far past them, counts the less)."""
    w0, w1 = (1.0 / line_carry_var(n, g) for n, g in rows)
    return float((w0 * d_px[0] + w1 * d_px[1]) / (w0 + w1))


# a steep parent side's value at the fork is off, besides its rows' noise (line_carry_var), by an offset its
# rows share (px^2: sd ~0.14 px; sides reaching the fork, docs/localize-edges24.md) and by the parent bending in
# depth between its nearest row and the fork, which a line through its rows does not follow: ~0.01 px per row
# carried beyond the first 2 (the true axis's own straight line there: 0.08 px rms for reads reaching the fork,
# 0.14-0.19 px for reads 6-30 px short; docs/localize-forkcurve25.md)
SIDE_OFFSET_VAR = 0.02
SIDE_BEND_PX_PER_ROW = 0.01
SIDE_BEND_FREE_PX = 2.0
SIDE_ROW_VAR = 0.04                 # (px^2: one row's noise, the unit of line_carry_var, where the rows count)


def side_carry_var(n_rows: float, gap_rows: float, rows: bool = True) -> float:
    """Variance (px^2) of a steep parent side's disparity at a fork from ``n_rows`` rows (or a fitted
    span of that many rows) carried ``gap_rows`` past the nearest: the offset its rows share
    (``SIDE_OFFSET_VAR``), the parent's bend in depth over the carry beyond ``SIDE_BEND_FREE_PX``
    (``SIDE_BEND_PX_PER_ROW`` per row, squared) and, with ``rows``, the rows' noise carried
    (``SIDE_ROW_VAR`` times :func:`line_carry_var`)."""
    bend = SIDE_BEND_PX_PER_ROW * max(float(gap_rows) - SIDE_BEND_FREE_PX, 0.0)
    v = SIDE_OFFSET_VAR + bend * bend
    return v + SIDE_ROW_VAR * line_carry_var(n_rows, gap_rows) if rows else v


# ... for two sides each read on at least this many rows (SideNear.n_rows) or, not read, fitted on a span of at
# least this many: a side on fewer rows, or a short piece's curve, is off by more than its carry tells (seed 564
# T7, colour: -0.83 px on 15 rows against -0.23 on 53, both reaching the fork; seed 137 T7: a span of 5 rows,
# +1.99 px)
SIDE_BENT_MIN_ROWS = 16
SIDE_BENT_MIN_SPAN = 40.0


def bent_sides_apply(rows, read) -> bool:
    """Whether a fork's two steep parent sides are weighed by :func:`weigh_bent_sides`: each, with its
    (rows, rows carried) in ``rows`` and whether it was read from its own crossings in ``read``, read on at
    least ``SIDE_BENT_MIN_ROWS`` rows or, not read, fitted on a span of at least ``SIDE_BENT_MIN_SPAN`` rows."""
    return all(n >= (SIDE_BENT_MIN_ROWS if r else SIDE_BENT_MIN_SPAN) for (n, _), r in zip(rows, read))


def weigh_bent_sides(d_px, rows, with_rows: bool) -> float:
    """A fork's disparity from its two steep parent sides' values ``d_px`` (2,), each weighted by the
    inverse of :func:`side_carry_var` of its (rows, rows carried) in ``rows`` ((n, g) per side): a side
    carried further from its rows counts the less (the parent bends in depth in between); with
    ``with_rows`` its rows' noise counts too (sides that disagree beyond it: :func:`weigh_sides`'s
    case). Equal variances give the plain mean, ``(d0 + d1) / 2``."""
    v0, v1 = (side_carry_var(n, g, with_rows) for n, g in rows)
    if v0 == v1:
        return float((d_px[0] + d_px[1]) / 2)
    w0, w1 = 1.0 / v0, 1.0 / v1
    return float((w0 * d_px[0] + w1 * d_px[1]) / (w0 + w1))


# a flat parent side's disparity at a fork: its bark texture on patches from the fork this far along it
FLAT_NEAR_PX = 24.0
FLAT_STEP_PX = 6.0
# each patch's value is carried to the fork along the curve's own slope (a branch turning in depth
# along it: the patches' median lies ~12 px in)
FLAT_ALONG = True
# a patch counts only where the share of it on the branch in the left view and in the right (at the
# curve's disparity) differ by at most this (a leaf in front of the side next to the fork, at its own
# depth, read instead: seed 454 T11, -2.1 px; localize/patchmask.py); None: all count
FLAT_NEAR_MAX_SHARE_DIFF = 0.15
# a flat side whose curve turns in depth faster than this at the fork (px of disparity per px along it) is not read
# there: a patch 25 px along the rows then spans over 3 px of disparity, its correlation peak is the bark's at
# either end as much as at its middle (seed 821 T11, exact masks: a side turning 0.19 px per px, its 4 patches
# 142.1-143.6 px, scaled MAD 0.79, carried to the fork at +1.31 px where its curve read -0.34: -11.4 mm). The
# feature check's pieces likewise give no verdict beyond featurecheck.MAX_PIECE_SLOPE (0.12); None: always read
FLAT_NEAR_MAX_SLOPE = 0.12
# a flat side whose centre line carried to the fork passes it FLAT_NEAR_SHIFT_MIN_R of the parent's radius or more
# away (its fit's end bends off, the parent bends at the fork) has its patches moved by that offset onto the fork
# (``at_uv``): read along the carried line they lie on the branch's upper or lower part, where the surface is further
# than the front that surface_to_axis takes off (seed 1074 T9, colour masks: 6.2 px off at r 8.9 px, -0.61 px; moved
# -0.44 px, the fork +3.97 -> +1.78 mm; forkends.FLAT_NEAR_SHIFT_UNMOVED, FLAT_NEAR_SHIFT_READ bound it)
FLAT_NEAR_SHIFT = True
FLAT_NEAR_SHIFT_MIN_R = 0.5


def flat_side_near(c: BranchCurve, left_gray: np.ndarray, right_gray: np.ndarray, t_fork: float, f_px: float,
                   offset_px: float = 0.0, reach_px: float = FLAT_NEAR_PX, step_px: float = FLAT_STEP_PX,
                   min_score: float = 0.6, tol_d_px: float = 2.5, min_patches: int = 3,
                   radius_px: float | None = None, left_mask: np.ndarray | None = None,
                   right_mask: np.ndarray | None = None, at_uv: np.ndarray | None = None) -> SideNear | None:
    """A flat parent side's disparity at a fork from its bark texture next to the fork.

    A flat piece's disparity is a constant (pieces under 100 px) or a line fitted to texture patches
    along the whole piece, leaving out the junction's blob; where the branch turns in depth along it,
    the fit read at the fork is a few tenths of a pixel off the fork's own depth (the fork often lies
    tens of px past the span). The patches on the side's centre line (carried past its span) from the
    fork to ``reach_px`` along the side, matched along the rows (normalised cross-correlation as
    ``texture.surface_disparity``, searched within 3 px of the curve's value) and moved back onto the axis, give the side's disparity
    there: their median (each carried to the fork along the curve's slope), of those correlating at
    ``min_score`` and within ``tol_d_px`` of the curve.
    At the fork the child is at the parent's depth, so its bark in a patch does not bias it.

    Parameters
    ----------
    c : BranchCurve
        The side's curve (flat: parameter = column; a steep one gives None).
    left_gray, right_gray : ndarray (H, W) uint8
        Rectified grey images.
    t_fork : float
        The fork's column on the side's curve.
    f_px, offset_px : float
        Focal length and the principal-point difference (``texture.surface_to_axis``).
    radius_px : float, optional
        The parent's radius at the fork (the surface-to-axis step and the search's centre; the patches
        keep the side's height, as the flat fit's); by default
        the side's own (its span's, which for a tapering branch is the radius tens of px away: the
        distal side thinner than at the fork, its texture's axis read too near, the proximal one too far).
    left_mask, right_mask : ndarray (H, W) uint8, optional
        Branch coverage 0-255 of the two views: a patch counts only where its share on the branch in the
        left view and in the right at the curve's disparity differ by at most ``FLAT_NEAR_MAX_SHARE_DIFF``
        (not a leaf in front of the side in one view: :func:`patchmask.share_difference`); None: every
        patch counts.
    at_uv : ndarray (2,), optional
        The fork (px): where the side's line at ``t_fork`` passes it ``FLAT_NEAR_SHIFT_MIN_R`` radii or more away,
        the patches are moved by that offset (``FLAT_NEAR_SHIFT``).

    Returns
    -------
    SideNear or None
        None when fewer than ``min_patches`` patches hold.
    """
    if c.by_row or not math.isfinite(t_fork) or turns_in_depth(c, t_fork):
        return None
    lo, hi = c.t_range
    sg = 1.0 if (t_fork < lo or (t_fork <= hi and t_fork < 0.5 * (lo + hi))) else -1.0
    dt = np.arange(0.0, reach_px + 0.5 * step_px, step_px)
    t = t_fork + sg * dt
    uv = c.uv_at(t)
    d_c = float(c.d_at(t_fork)[0])
    r = c.radius_px if radius_px is None else float(radius_px)
    if at_uv is not None:
        off = flat_near_offset(c, t_fork, at_uv, r)
        if off is not None:
            uv = uv + off
    scale = 1.0 + r / f_px
    d_s = (d_c - offset_px) * scale + offset_px          # the curve's value on the surface
    hh = max(1, int(0.6 * c.radius_px))                 # (the flat fit's patches: the side's own radius)
    d_surf, score = _patch_disparity(left_gray, right_gray, uv, hh, 12,
                                     int(math.floor(d_s - 3.0)), int(math.ceil(d_s + 3.0)))
    ok = np.isfinite(d_surf) & (score >= min_score)
    if left_mask is not None and right_mask is not None and FLAT_NEAR_MAX_SHARE_DIFF is not None:
        ok &= share_difference(left_mask, right_mask, uv, c.d_at(t), hh, 12) <= FLAT_NEAR_MAX_SHARE_DIFF
    if np.count_nonzero(ok) < min_patches:
        return None
    d_ax = surface_to_axis(d_surf[ok], r, f_px, offset_px,     # (compiled: patch_depth_fraction(r, hh)'s value)
                           np.float64(kernels_forknear.depth_fraction(float(r), hh)))
    if FLAT_ALONG:      # each patch's value carried to the fork along the curve's own slope
        d_ax = d_ax - (c.d_at(t[ok]) - d_c)
    keep = np.abs(d_ax - d_c) <= tol_d_px
    if np.count_nonzero(keep) < min_patches:
        return None
    d_ax, x = d_ax[keep], dt[ok][keep]
    m = float(median(d_ax))
    mad = 1.4826 * float(median(np.abs(d_ax - m)))
    return SideNear(m, len(d_ax), 0, int(max(lo - t_fork, t_fork - hi, 0.0)), float(x.min()), mad, 0.0)


def flat_near_offset(c: BranchCurve, t_fork: float, at_uv, radius_px: float) -> np.ndarray | None:
    """The offset (px, (2,)) from a flat side's centre line at ``t_fork`` to the fork ``at_uv`` where it is
    ``FLAT_NEAR_SHIFT_MIN_R`` of the radius ``radius_px`` or more (``FLAT_NEAR_SHIFT``); else None."""
    if not FLAT_NEAR_SHIFT:
        return None
    off = np.asarray(at_uv, float) - c.uv_at(np.array([t_fork]))[0]
    return off if math.hypot(off[0], off[1]) >= FLAT_NEAR_SHIFT_MIN_R * radius_px else None


def turns_in_depth(c: BranchCurve, t_px: float, max_slope: float | None = None) -> bool:
    """Whether a flat side's curve ``c`` turns in depth at its parameter ``t_px`` (px) faster than ``max_slope``
    (px of disparity per px of its parameter; None: ``FLAT_NEAR_MAX_SLOPE``, read at the call; that None too:
    never), its slope taken over the 2 px about ``t_px`` (the curve's end slopes past its span)."""
    lim = FLAT_NEAR_MAX_SLOPE if max_slope is None else max_slope
    if lim is None:
        return False
    d0, d1 = c.d_at(np.array([t_px - 1.0, t_px + 1.0])).tolist()
    return abs(d1 - d0) > 2.0 * lim


def taper_radius(r_a_px: float, dist_a_px: float, r_b_px: float, dist_b_px: float) -> float:
    """A tapering branch's radius (px) at a point between two stretches of it of radii ``r_a_px`` and
    ``r_b_px`` (each their mean, so their middle's) ``dist_a_px`` and ``dist_b_px`` away: linear along
    the branch (a branch's radius falls evenly from its base to its tip)."""
    return (r_a_px * dist_b_px + r_b_px * dist_a_px) / max(dist_a_px + dist_b_px, 1e-9)


def _patch_disparity(left: np.ndarray, right: np.ndarray, uv: np.ndarray, hh: int, hw: int, lo: int,
                     hi: int) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel disparity (N,) of the (2 hh + 1) x (2 hw + 1) patches centred on ``uv`` (N, 2) (rounded)
    searched along the row over ``lo``-``hi`` px, and their correlation (TM_CCOEFF_NORMED, as
    :func:`texture.surface_disparity` for a few patches: each image read once over the patches' box;
    NaN / -1 where a patch or its strip leaves the image or the patch is flat)."""
    h, w = left.shape
    n = len(uv)
    d_out, score = np.empty(n), np.empty(n)        # (np.full's values, without its wrapper)
    d_out.fill(np.nan)
    score.fill(-1.0)
    ui = np.rint(uv).astype(int)
    y0, y1 = int(ui[:, 1].min()) - hh, int(ui[:, 1].max()) + hh + 1
    x0, x1 = int(ui[:, 0].min()) - hw, int(ui[:, 0].max()) + hw + 1
    if y0 < 0 or y1 > h or x0 - hi < 0 or x1 - lo > w or x0 < 0 or x1 > w:
        return d_out, score
    lbox = np.asarray(left[y0:y1, x0:x1])
    rbox = np.asarray(right[y0:y1, x0 - hi:x1 - lo])
    # (compiled, patch by patch: minMaxLoc's flat test, the NCC scores and the parabola; d8a16ad's loop is the
    # reference in test_kernels_forknear.py)
    kernels_forknear.patch_peaks(np.ascontiguousarray(lbox), np.ascontiguousarray(rbox),
                                 np.ascontiguousarray(ui, np.int64), int(hh), int(hw), int(lo), int(hi), y0, x0,
                                 d_out, score)
    return d_out, score


def _carried(c: BranchCurve, end: float) -> tuple[float, float, float, float, float]:
    """The curve's tangent at the span's ``end``: its centre column and slope, its disparity and slope
    there (beyond the span: as :meth:`BranchCurve.s_at` / ``d_at`` carry it; on the span's rows next to
    its end within a fraction of a pixel: they only pick the crossings, within 1.5 and 2.5 px), and the
    ratio of the right view's row crossing width to the left's.

    A band of width W at slope s (columns per row) crosses a row over W sqrt(1 + s^2); in the right
    view the centre line is the left one moved by the disparity, so its slope is s - d'(t): a piece
    turning in depth along an oblique stretch (|s| ~2, d' ~0.15 px per row) is crossed 1-4 px
    narrower or wider there, on every row alike.
    """
    lo, _ = c.t_range
    slope_d = c.d_poly.deriv().at(end) if c.d_end_slopes is None else c.d_end_slopes[0 if end == lo else 1]
    slope_s = c.s_poly.deriv().at(end)
    ratio = math.hypot(1.0, slope_s - slope_d) / math.hypot(1.0, slope_s) if SIDE_WIDTH_SLOPE else 1.0
    return float(c.s_poly.at(end)), float(slope_s), float(c.d_poly.at(end)), float(slope_d), float(ratio)


@dataclass(frozen=True)
class SideNear:
    """A parent side's disparity at a fork from its crossings nearest it (:func:`side_disparity_near`).

    Attributes
    ----------
    d_px : float
        The side's disparity at the fork's row.
    n_rows, n_gap_rows : int
        Rows kept by the line fit, and those of them between the span and the fork.
    gap_px : int
        Rows between the span's end and the fork.
    nearest_px : float
        The kept row nearest the fork: how far the line is carried.
    mad_px : float
        Scaled MAD of the kept rows about the line.
    slope : float
        The line's slope (px of disparity per row).
    """

    d_px: float
    n_rows: int
    n_gap_rows: int
    gap_px: int
    nearest_px: float
    mad_px: float
    slope: float
