"""forkends: the helpers of ForkPlacing that need no scene."""

import numpy as np
import pytest

from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.forkends import walk_reach_t


@pytest.mark.parametrize("by_row", [True, False])
@pytest.mark.parametrize("deg", [0.0, 24.0, 60.0])
def test_a_hidden_ends_walk_reaches_its_px_along_the_branch_whatever_its_slant(by_row, deg):
    # a straight piece at `deg` to its parameter's axis (rows of a steep piece, columns of a flat one),
    # walked out past either end: the walk's length in the image is the reach in px, not in rows
    t = np.linspace(100.0, 300.0, 21)
    s_poly = Poly.fit(t, 50.0 + np.tan(np.radians(deg)) * t, 1)
    c = BranchCurve(0, by_row, (100.0, 300.0), s_poly, Poly.fit(t, 150.0 + 0.0 * t, 1), 5.0, 21)
    for t_edge, sign in ((300.0, 1.0), (100.0, -1.0)):
        reach_t = walk_reach_t(c, t_edge, sign, 80.0)
        uv = c.uv_at(np.array([t_edge, t_edge + sign * reach_t]))
        assert np.hypot(*(uv[1] - uv[0])) == pytest.approx(80.0, abs=1e-6)
        assert reach_t == pytest.approx(80.0 * np.cos(np.radians(deg)), abs=1e-6)


@pytest.mark.parametrize("rule", [False, True])
def test_a_side_read_next_to_the_fork_stands_alone_against_one_known_only_by_the_floor(monkeypatch, rule):
    # seed 772 T9 (exact masks): a steep side (rows 140-159) read from its own crossings 3 rows from the fork at
    # (435, 182), 190.18 px (truth 190.15); a flat side fitted on columns 446-453 only, carried 11 columns to the
    # fork, 184.81 (known by _reach's 12 px floor, not by its span); the child carried 41 px, 189.29. Both sides
    # counted as known, _known_disparity kept the median of three (the child): +4.3 mm. With the rule the read side.
    from appliance.localize import forkends
    from appliance.localize.forkdisp import SideNear
    monkeypatch.setattr(forkends, "FLOOR_SIDE_UNKNOWN_BY_READ", rule)
    fp = forkends.ForkPlacing.__new__(forkends.ForkPlacing)
    t = np.linspace(0.0, 1.0, 5)
    steep = BranchCurve(1, True, (140.0, 159.0), Poly.fit(140.0 + 19 * t, 420.0 + 0 * t, 1),
                        Poly.fit(140.0 + 19 * t, 191.0 + 0 * t, 1), 8.6, 20)
    flat = BranchCurve(2, False, (446.0, 453.0), Poly.fit(446.0 + 7 * t, 185.0 + 0 * t, 1),
                       Poly.fit(446.0 + 7 * t, 184.8 + 0 * t, 1), 8.9, 8)
    child = BranchCurve(3, False, (292.0, 394.0), Poly.fit(292.0 + 102 * t, 150.0 + 0 * t, 1),
                        Poly.fit(292.0 + 102 * t, 189.3 + 0 * t, 1), 8.5, 103)
    fp.curves = {1: steep, 2: flat, 3: child}
    values = {1: 190.18, 2: 184.81, 3: 189.29}
    xy = np.array([435.3, 182.3])
    near = {1: SideNear(190.18, 12, 3, 23, 3.29, 0.42, -0.056)}
    d_known = fp._known_disparity([1, 2], 3, True, xy, 189.29, values.get, near)
    if rule:
        assert d_known == pytest.approx(190.18)
    else:
        assert d_known is None
    # a side known by its own span stays known with the read one: both known, the fork keeps its disparity
    fp.curves[2] = BranchCurve(2, False, (430.0, 453.0), flat.s_poly, flat.d_poly, 8.9, 24)
    assert fp._known_disparity([1, 2], 3, True, xy, 189.29, values.get, near) is None


@pytest.mark.parametrize("slope", [0.0, 1.24])
@pytest.mark.parametrize("span", [(446.0, 453.0), (430.0, 453.0)])
def test_a_short_flat_side_turning_in_depth_leaves_the_mean_of_the_sides(slope, span):
    # seed 772 T9 (colour masks): a steep side (rows 140-162) and a flat side fitted on columns 446-453 with a
    # disparity slope of 1.24 px per px, carried 10.7 columns to the fork at (436.3, 182.8): its end slope carried,
    # 1.79 px low; their plain mean took half of that (+6.1 mm). Such a side leaves the mean; a side flat in depth
    # or fitted on 23 columns (vouched for by its span) stays, and so does any side read next to the fork.
    from appliance.localize import forkends
    from appliance.localize.forkdisp import SideNear
    fp = forkends.ForkPlacing.__new__(forkends.ForkPlacing)
    t = np.linspace(0.0, 1.0, 5)
    steep = BranchCurve(1, True, (140.0, 162.0), Poly.fit(140.0 + 22 * t, 420.0 + 0 * t, 1),
                        Poly.fit(140.0 + 22 * t, 191.0 + 0 * t, 1), 8.6, 23)
    cols = span[0] + (span[1] - span[0]) * t
    flat = BranchCurve(2, False, span, Poly.fit(cols, 185.0 + 0 * t, 1),
                       Poly.fit(cols, 201.8 + slope * (cols - 446.0), 1), 8.9, 8)
    fp.curves = {1: steep, 2: flat}
    xy = np.array([436.3, 182.8])
    out = fp._mean_sides([1, 2], xy, {})
    assert out == ([1] if slope > 0 and span[0] == 446.0 else [1, 2])
    # read next to the fork by its texture: it stays
    assert fp._mean_sides([1, 2], xy, {2: SideNear(188.4, 5, 0, 5, 0.0, 0.3, 0.0)}) == [1, 2]
    # two such sides: nothing tells which, both stay; one side: unchanged
    if out != [1]:
        return
    fp.curves[1] = BranchCurve(1, False, (425.0, 432.0), flat.s_poly, Poly.fit(425.0 + 7 * t, 180.0 - 1.24 * 7 * t, 1),
                               8.6, 8)
    assert fp._mean_sides([1, 2], xy, {}) == [1, 2]
    assert fp._mean_sides([2], xy, {}) == [2]


def _bent_pair(h: int = 400, w: int = 320, fork_row: float = 150.0, above: int = 3, below: int = 15):
    """A steep parent (half width 10 px, centre column 150 + 0.1 v) as coverage in both views, its disparity
    40 + 0.01 v + 0.0002 (v - fork_row)^2 (bending in depth about the fork), the rows from ``above`` above the fork to
    ``below`` below it widened 8 px on the left in both views (a child leaving down there, or the parent's outline
    joining a child's): the two views' runs and the disparity."""
    from appliance.localize.edges import find_runs
    v = np.arange(h, dtype=float)[:, None]
    u = np.arange(w, dtype=float)[None, :]
    d = lambda r: 40.0 + 0.01 * r + 0.0002 * (r - fork_row) ** 2
    runs = []
    for shift in (0.0 * v, d(v)):
        c = 150.0 + 0.1 * v - shift
        lo = c - 10.0 - np.where((v >= fork_row - above) & (v <= fork_row + below), 8.0, 0.0)
        cov = np.clip(np.minimum(u - lo, c + 10.0 - u) + 0.5, 0.0, 1.0)
        runs.append(find_runs(np.rint(255 * cov).astype(np.uint8), soft=True))
    return runs, d


@pytest.mark.parametrize("other_rows", [0.0, 60.0])
def test_a_lone_side_short_of_the_fork_is_read_through_it_where_the_parent_runs_on(monkeypatch, other_rows):
    # a lone steep side fitted on rows 200-300, its own read stopping 15 rows short of the fork at row 150 (the
    # crotch's widened rows left out), the parent bending in depth there: where the other parent piece (no curve)
    # runs on 60 rows past the fork, the side is read through it, its crossings 4+ rows past it too (forkdisp.
    # side_through_fork); a piece ending at the fork leaves the side's own read
    from types import SimpleNamespace

    from appliance.localize import forkends
    from appliance.localize.forkdisp import side_disparity_near
    (runs_l, runs_r), d = _bent_pair()
    t = np.arange(200.0, 301.0)
    c = BranchCurve(1, True, (200.0, 300.0), Poly.fit(t, 150.0 + 0.1 * t, 1), Poly.fit(t, d(t), 1), 10.0, len(t))
    fp = forkends.ForkPlacing.__new__(forkends.ForkPlacing)
    fp.curves, fp.runs_l, fp.runs_r = {1: c}, runs_l, runs_r
    fp.sm = SimpleNamespace(left_mask=np.zeros((400, 320), np.uint8), f_px=1450.0, cx_px=160.0, offset_px=0.0)
    fp.seg_points = lambda s: np.array([[135.0, 150.0 - other_rows], [150.0, 150.0]])
    xy = np.array([165.0, 150.0])
    v0 = side_disparity_near(c, runs_l, runs_r, 150.0, f_px=1450.0, cx_px=160.0, offset_px=0.0)
    assert v0 is not None and v0.nearest_px >= 15.0 and abs(v0.d_px - d(150.0)) >= 0.1
    v = fp._through_fork(1, 2, xy, v0)
    if other_rows == 0.0:
        assert v is None
        return
    assert v is not None and abs(v.d_px - d(150.0)) <= 0.5 * abs(v0.d_px - d(150.0))
    # ... but not where it would move the side's value by more than THROUGH_MAX_MOVE_PX (another branch's rows)
    monkeypatch.setattr(forkends, "THROUGH_MAX_MOVE_PX", 0.5 * abs(v.d_px - v0.d_px))
    assert fp._through_fork(1, 2, xy, v0) is None
    # ... nor where the side's own read reaches the fork
    assert fp._through_fork(1, 2, xy, v0.__class__(v0.d_px, v0.n_rows, v0.n_gap_rows, v0.gap_px, 2.0, 0.1, 0.0)) \
        is None


@pytest.mark.parametrize("crotch_rows", [4, 15])
def test_a_steep_childs_own_rows_next_to_the_fork_are_read_where_they_come_near_it(crotch_rows):
    # a steep child fitted on rows 200-300, its fork at row 150 on a flat parent whose outline widens the child's
    # crossings on the rows within `crotch_rows` of the fork: its own rows clear of them, read as a parent side's,
    # give its disparity at the fork where they come within FLAT_CHILD_READ_PX (12) of it; from further, none
    from types import SimpleNamespace

    from appliance.localize import forkends
    (runs_l, runs_r), d = _bent_pair(above=crotch_rows, below=crotch_rows)
    t = np.arange(200.0, 301.0)
    c = BranchCurve(1, True, (200.0, 300.0), Poly.fit(t, 150.0 + 0.1 * t, 1), Poly.fit(t, d(t), 1), 10.0, len(t))
    fp = forkends.ForkPlacing.__new__(forkends.ForkPlacing)
    fp.curves, fp.runs_l, fp.runs_r = {1: c}, runs_l, runs_r
    fp.sm = SimpleNamespace(f_px=1450.0, cx_px=160.0, offset_px=0.0)
    v = fp._child_read(1, np.array([165.0, 150.0]))
    # (a reach of its own: LONE_FLAT_CHILD_READ_PX, 15)
    v_far = fp._child_read(1, np.array([165.0, 150.0]), crotch_rows + 2.0)
    assert v_far is not None and v_far.nearest_px <= crotch_rows + 1.0
    assert fp._child_read(1, np.array([165.0, 150.0]), crotch_rows - 2.0) is None
    if crotch_rows > forkends.FLAT_CHILD_READ_PX:
        assert v is None
    else:
        assert v is not None and v.nearest_px <= crotch_rows + 1.0
        assert abs(v.d_px - d(150.0)) < abs(float(c.d_at(np.array([150.0]))[0]) - d(150.0))   # nearer than its fit
