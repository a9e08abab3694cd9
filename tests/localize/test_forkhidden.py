"""A hidden fork's parent disparity from its own crossings clear of the crotch (appliance.localize.forkhidden)."""

import math

import numpy as np
import pytest
from appliance.localize import forkhidden
from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.edges import find_runs
from appliance.localize.forkdisp import SideNear, weigh_bent_sides
from appliance.localize.forkhidden import (CROTCH_MIN_ROWS, crotch_half_px, hidden_parent_disparity,
                                           hidden_side_reads)

H, W = 400, 320


def u_axis(v):
    return 150.0 + 0.1 * v


def d_axis(v):                        # the parent leans in depth: 0.01 px of disparity per row
    return 40.0 + 0.01 * v


def band(shift_px, fork_row: float, child_px: float = 0.0, rows=(0, H)) -> np.ndarray:
    """A steep parent (half width 10 px) on ``rows`` as coverage 0-255, moved left by ``shift_px(v)``; rows
    within 12 of ``fork_row`` widened by ``child_px`` on the left (the child joining it there)."""
    v = np.arange(H, dtype=float)[:, None]
    u = np.arange(W, dtype=float)[None, :]
    c = u_axis(v) - shift_px(v)
    lo = c - 10.0 - np.where(np.abs(v - fork_row) <= 12, child_px, 0.0)
    cov = np.clip(np.minimum(u - lo, c + 10.0 - u) + 0.5, 0.0, 1.0)
    cov[(v[:, 0] < rows[0]) | (v[:, 0] >= rows[1])] = 0.0
    return np.rint(255 * cov).astype(np.uint8)


def runs_pair(fork_row: float, child_px: float, rows=(0, H)):
    return (find_runs(band(lambda v: 0.0 * v, fork_row, child_px, rows), soft=True),
            find_runs(band(d_axis, fork_row, child_px, rows), soft=True))


def bent_fit(lo: float, hi: float, fork_row: float, bend_px: float) -> BranchCurve:
    """The parent's piece fitted on rows ``lo``-``hi``, its disparity bending by up to ``bend_px`` over the
    crotch's rows (within 12 of ``fork_row``: the child widening the silhouette there)."""
    t = np.arange(lo, hi + 1.0)
    d = d_axis(t) + bend_px * np.clip(1.0 - np.abs(t - fork_row) / 12.0, 0.0, 1.0)
    return BranchCurve(0, True, (lo, hi), Poly.fit(t, u_axis(t), 1), Poly.fit(t, d, 5), 10.0, len(t))


def test_a_fork_at_the_span_end_is_read_from_the_parents_rows_clear_of_the_crotch():
    # fixture 00 T11's case: the crossing 1 row past the parent's span, whose fit bends into the crotch's rows
    fork = 301.0
    c = bent_fit(100.0, 300.0, fork, 1.2)
    assert abs(float(c.d_at(np.array([fork]))[0]) - d_axis(fork)) >= 0.5      # the curve there: off
    reads = hidden_side_reads(c, *runs_pair(fork, 8.0), fork, clear_t=15.0)
    assert len(reads) == 1                          # (no span past the fork: one side)
    assert abs(hidden_parent_disparity(reads) - d_axis(fork)) <= 0.05
    # the crotch's widened rows are not the parent's alone: the line stops short of them
    assert reads[0].nearest_px >= 12.0


def test_a_fork_within_the_span_keeps_its_curve_or_is_read_on_both_sides_and_weighed(monkeypatch):
    fork = 220.0
    # the span runs on past the crotch on both sides: its fit goes through both, read as it is
    assert hidden_side_reads(bent_fit(100.0, 340.0, fork, 3.0), *runs_pair(fork, 8.0), fork, clear_t=15.0) == []
    monkeypatch.setattr(forkhidden, "SPAN_END_ONLY", False)
    c = bent_fit(100.0, 340.0, fork, 3.0)
    assert abs(float(c.d_at(np.array([fork]))[0]) - d_axis(fork)) >= 0.4
    reads = hidden_side_reads(c, *runs_pair(fork, 8.0), fork, clear_t=15.0)
    assert len(reads) == 2
    assert all(abs(v.d_px - d_axis(fork)) <= 0.05 for v in reads)
    assert abs(hidden_parent_disparity(reads) - d_axis(fork)) <= 0.05
    # a side whose part past the cut is shorter than SIDE_MIN_SPAN_ROWS is not read: the fork 20 rows into the span
    near_lo = hidden_side_reads(bent_fit(100.0, 340.0, 120.0, 1.2), *runs_pair(120.0, 8.0), 120.0, clear_t=15.0)
    assert len(near_lo) == 1 and abs(near_lo[0].d_px - d_axis(120.0)) <= 0.05


def test_a_flat_parent_or_a_parent_hidden_in_the_right_view_gives_no_read():
    fork = 301.0
    c = bent_fit(100.0, 300.0, fork, 1.2)
    flat = BranchCurve(0, False, c.t_range, c.s_poly, c.d_poly, 10.0, c.n_samples)
    assert hidden_side_reads(flat, *runs_pair(fork, 8.0), fork, clear_t=15.0) == []
    # the right view shows nothing of the parent: no crossings to read, the curve stands (None)
    runs_l = find_runs(band(lambda v: 0.0 * v, fork, 8.0), soft=True)
    runs_r = find_runs(band(d_axis, fork, 8.0, rows=(0, 0)), soft=True)
    reads = hidden_side_reads(c, runs_l, runs_r, fork, clear_t=15.0)
    assert reads == [] and hidden_parent_disparity(reads) is None


def test_the_cut_is_at_least_the_least_gap_a_side_is_read_across():
    # a cut under SIDE_GAP_MIN_PX would leave the fork "within the span" for side_disparity_near: raised to
    # CROTCH_MIN_ROWS, so a thin child at a right angle still gets its parent read
    fork = 301.0
    c = bent_fit(100.0, 300.0, fork, 1.2)
    reads = hidden_side_reads(c, *runs_pair(fork, 0.0), fork, clear_t=1.0)
    assert len(reads) == 1 and reads[0].gap_px >= int(CROTCH_MIN_ROWS)


@pytest.mark.parametrize("deg", [30.0, 60.0, 90.0])
def test_the_crotch_spans_the_childs_footprint_on_the_parents_outline(deg):
    s = math.sin(math.radians(deg))
    r_c, r_p = 5.0, 12.0
    half = crotch_half_px(r_c, r_p, s)
    # the child's two edges (its centre line through the origin at deg to the parent's axis) meet the outline
    # (r_p off the axis) at r_p cot +- r_c / sin along it: the farther one is the half length, plus the pad
    cot = math.cos(math.radians(deg)) / s
    assert half == pytest.approx(r_p * cot + r_c / s + 2.0)
    assert crotch_half_px(r_c, r_p, 0.05) == crotch_half_px(r_c, r_p, 0.2)    # (shallow: capped)


def test_two_sides_are_weighed_by_their_carry_as_a_forks_sides():
    near = SideNear(40.0, 40, 0, 15, 15.0, 0.1, 0.0)
    far = SideNear(41.0, 40, 0, 40, 40.0, 0.1, 0.0)
    d = hidden_parent_disparity([near, far])
    assert d == pytest.approx(weigh_bent_sides([40.0, 41.0], [(40, 15.0), (40, 40.0)], True))
    assert 40.0 < d < 40.5                     # the side carried less counts the more
    assert hidden_parent_disparity([far]) == 41.0
    few = SideNear(41.0, 13, 0, 15, 15.0, 0.1, 0.0)          # (too few rows to weigh by the carry: by the rows)
    assert 40.0 < hidden_parent_disparity([near, few]) < 41.0
