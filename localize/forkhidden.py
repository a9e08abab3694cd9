"""A hidden fork's parent disparity from the parent's own row crossings clear of the crotch.

``ForkPlacing.hidden_fork`` places a hidden end where its centre line, carried on behind the
occluder, crosses a thicker piece (the parent). The parent's fitted curve read at that crossing is
often ~1 px off where the crossing lies at or near the span's end: the child widens the
silhouette over the crotch's rows and the fit bends into them (docs/localize-softfork25.md,
fixture 00 T11: +1.61 px, -11 mm). As :meth:`ForkPlacing.fork` does for a fork's parent sides
(:func:`forkdisp.side_disparity_near`), the parent is read instead from its own crossings on each
side of the crotch: its span cut short of the crotch, and a line through its rows next to the cut
(the crotch's rows as wide as the parent's only) read at the fork's row; two sides are weighed as
``fork`` weighs its two parent sides (:func:`forkdisp.weigh_bent_sides`, :func:`forkdisp.weigh_sides`).
"""

from __future__ import annotations

import dataclasses
import math

from appliance.localize.curves import BranchCurve
from appliance.localize.edges import Runs
from appliance.localize.forkdisp import (SIDE_GAP_MIN_PX, SideNear, bent_sides_apply, side_disparity_near,
                                         weigh_bent_sides, weigh_sides)

# the crotch's half length along the parent beyond the child's own footprint (px), and the least cut (rows:
# side_disparity_near reads a side only where the fork lies further than SIDE_GAP_MIN_PX past its span)
CROTCH_PAD_PX = 2.0
CROTCH_MIN_ROWS = SIDE_GAP_MIN_PX + 1.0
# a side of the parent's span shorter than this (rows) past the cut is not read
SIDE_MIN_SPAN_ROWS = 12.0
# only a fork whose crotch reaches the span's end is read (one side of it left): a span running on past the crotch
# on both sides is fitted through both, the crotch's rows a small share of them (fixture 00 T7, mid-span in a
# 195-row parent: its curve +0.12 / +0.01 px, its two sides read +0.27 / +0.11)
SPAN_END_ONLY = True
# two sides further apart than this (px) are weighed with their rows' noise too (ForkPlacing.SIDES_WEIGHT_PX)
SIDES_APART_PX = 0.5


def crotch_half_px(r_child_px: float, r_par_px: float, sin_t: float) -> float:
    """How far along the parent's axis (px) from where the child's centre line crosses it the child's
    silhouette joins the parent's: a band of half width ``r_child_px`` crossing at sine ``sin_t`` meets
    the parent's outline (``r_par_px`` off its axis) over ``r_child / sin + r_par |cot|`` on either side
    (the outline's crossing moved along by the angle), plus ``CROTCH_PAD_PX``."""
    s = max(abs(float(sin_t)), 0.2)
    return r_child_px / s + r_par_px * math.sqrt(max(1.0 - s * s, 0.0)) / s + CROTCH_PAD_PX


def hidden_side_reads(c: BranchCurve, runs_l: Runs, runs_r: Runs, t_fork: float, clear_t: float,
                      f_px: float | None = None, cx_px: float | None = None,
                      offset_px: float = 0.0) -> list[SideNear]:
    """A steep parent's disparity at a hidden fork's row from its own crossings on each side of the crotch.

    The parent's span is cut ``clear_t`` rows short of the fork on each side that reaches past it
    (at least ``SIDE_MIN_SPAN_ROWS`` rows left), and each part is read at the fork's row as a side
    whose fit stops there (:func:`forkdisp.side_disparity_near`: its crossings nearest the fork, as
    wide as the part's last rows, and the part's rows next to its end). With ``SPAN_END_ONLY`` only
    where one part is left (the crotch at the span's end: its fit bends into the crotch's rows there).

    Parameters
    ----------
    c : BranchCurve
        The parent's curve (by row; a flat one gives no read).
    runs_l, runs_r : Runs
        Both views' row crossings.
    t_fork : float
        The fork's row (where the child's line crosses the parent's).
    clear_t : float
        The crotch's half length in rows (at least ``CROTCH_MIN_ROWS`` used).
    f_px, cx_px, offset_px : float, optional
        As :func:`forkdisp.side_disparity_near` (the right crossing's expected width).

    Returns
    -------
    list of SideNear
        The sides read (0-2), the one before the fork's row first.
    """
    if not c.by_row or not math.isfinite(t_fork):
        return []
    lo, hi = c.t_range
    cut = max(float(clear_t), CROTCH_MIN_ROWS)
    parts = [(a, b) for a, b in ((lo, min(hi, t_fork - cut)), (max(lo, t_fork + cut), hi)) if b - a >= SIDE_MIN_SPAN_ROWS]
    if SPAN_END_ONLY and len(parts) == 2:
        return []
    out = []
    for a, b in parts:
        # (the part's own tangent at its cut: the curve's polynomial there, not the span's end slopes)
        part = dataclasses.replace(c, t_range=(float(a), float(b)), d_end_slopes=None)
        v = side_disparity_near(part, runs_l, runs_r, float(t_fork), f_px=f_px, cx_px=cx_px, offset_px=offset_px)
        if v is not None:
            out.append(v)
    return out


def hidden_parent_disparity(reads: list[SideNear]) -> float | None:
    """The parent's disparity (px) at a hidden fork from its sides' reads (:func:`hidden_side_reads`): one
    side's value, or two weighed as :meth:`ForkPlacing.fork` weighs two steep parent sides read from their
    own rows (by how far each is carried, :func:`forkdisp.weigh_bent_sides`, where both are read on enough
    rows; else, where they differ by more than ``SIDES_APART_PX``, by their lines' noise,
    :func:`forkdisp.weigh_sides`; else their mean). None without a read."""
    if not reads:
        return None
    if len(reads) == 1:
        return float(reads[0].d_px)
    d = [float(v.d_px) for v in reads]
    rows = [(float(v.n_rows), float(v.nearest_px)) for v in reads]
    apart = abs(d[0] - d[1]) > SIDES_APART_PX
    if bent_sides_apply(rows, [True, True]):
        return weigh_bent_sides(d, rows, apart)
    if apart:
        return weigh_sides(d, rows)
    return float((d[0] + d[1]) / 2)
