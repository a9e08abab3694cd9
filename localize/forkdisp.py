"""A fork's parent disparity from the parent's own crossings nearest the fork (improved variant).

A parent piece's fit leaves out its rows near the junction (the crotch's blob, 1.6 radii around the
skeleton junction, where the child widens the silhouette) and is carried to the fork along the
slope fitted to its last samples, sometimes 30-100 rows, often off by 0.5-1.5 px there. Most of
those rows still cross the parent alone, as wide as the piece's last fitted rows in both views,
and their disparities are as good as the fitted ones: a straight line through them and the
span's rows next to its end, read at the fork's row, is that side's disparity at the fork.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from appliance.localize.curves import median, robust_fit
from appliance.localize.edges import Runs


# a parent side's fit carried at least this far (px of its parameter) to the fork is read again from its
# own crossings nearest the fork; rows of the span next to its end taken with them
SIDE_GAP_MIN_PX = 12.0
SIDE_SPAN_ROWS = 40


def side_disparity_near(c, runs_l: Runs, runs_r: Runs, t_fork: float, gap_min_px: float = SIDE_GAP_MIN_PX,
                        span_rows: int = SIDE_SPAN_ROWS, tol_d_px: float = 2.5, width_tol_px: float = 1.2,
                        min_rows: int = 12) -> SideNear | None:
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

    Returns
    -------
    SideNear or None
        None when the fork lies within ``gap_min_px`` of the span (the fit is read there) or fewer
        than ``min_rows`` rows are found.
    """
    if not c.by_row:
        return None
    lo, hi = c.t_range
    if lo - gap_min_px < t_fork < hi + gap_min_px:
        return None
    end, sg = (lo, 1.0) if t_fork < lo else (hi, -1.0)
    n_gap = int(abs(t_fork - end))
    # the rows from the fork's to span_rows into the span (the first 20 of those also give the width)
    rows = end + sg * np.arange(-n_gap, span_rows + 1, dtype=float)
    rows = rows[rows >= 0]
    if len(rows) < min_rows:
        return None
    u = c.s_at(rows)
    d = c.d_at(rows)
    il = runs_l.find(rows, u)
    i0 = np.maximum(il, 0)
    w_l = runs_l.span_px[i0]
    c_l = runs_l.centre_px[i0]
    inside = sg * (rows - end) >= 0
    ref = (il >= 0) & inside & (sg * (rows - end) < 20)
    if not ref.any():
        return None
    w_end = float(median(w_l[ref]))
    ok = (il >= 0) & (np.abs(w_l - w_end) <= 0.1 * w_end + 1.5) & (np.abs(c_l - u) <= 0.15 * w_end + 1.5)
    q_idx = np.flatnonzero(ok)
    if len(q_idx) < min_rows:
        return None
    q, rr = runs_r.between(rows[q_idx].astype(np.int64), c_l[q_idx] - d[q_idx] - tol_d_px,
                           c_l[q_idx] - d[q_idx] + tol_d_px)
    if not len(q):
        return None
    cd = c_l[q_idx[q]] - runs_r.centre_px[rr]
    # (as wide in both views: a row whose one edge is ragged or cut in one view moves its middle)
    good = np.abs(runs_r.span_px[rr] - w_l[q_idx[q]]) <= width_tol_px
    q, cd = q[good], cd[good]
    if not len(q):
        return None
    # per row the right crossing nearest the carried disparity
    res = np.abs(cd - d[q_idx[q]])
    order = np.lexsort((res, q))
    first = order[np.concatenate([[True], q[order][1:] != q[order][:-1]])]
    rows_k = rows[q_idx[q[first]]]
    d_k = cd[first]
    if len(rows_k) < min_rows:
        return None
    poly, keep = robust_fit(rows_k - t_fork, d_k, 1)
    if keep.sum() < min_rows:
        return None
    gap_k = keep & ~inside[q_idx[q[first]]]
    res = d_k[keep] - poly(rows_k[keep] - t_fork)
    return SideNear(float(poly.at(0.0)), int(keep.sum()), int(gap_k.sum()), n_gap,
                    float(np.abs(rows_k[keep] - t_fork).min()),
                    1.4826 * float(median(np.abs(res - median(res)))),
                    float(poly.deriv().at(0.0)), float(c.d_at(np.array([t_fork]))[0]))


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
    d_curve_px : float
        The side's fitted curve carried to the fork, for comparison.
    """

    d_px: float
    n_rows: int
    n_gap_rows: int
    gap_px: int
    nearest_px: float
    mad_px: float
    slope: float
    d_curve_px: float
