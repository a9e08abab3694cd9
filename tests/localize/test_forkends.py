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



def _placer_over(skel_img: np.ndarray):
    """An ``EndPlacer`` over a drawn one-pixel skeleton (no curves, blank views) and its junction nodes, left first."""
    from appliance.config import load_config
    from appliance.localize.ends import EndPlacer
    from appliance.localize.graph import JUNCTION, build_graph
    from appliance.localize.matching import StereoMasks
    from appliance.localize.radius import ridge_radius_map
    from appliance.localize.skeleton import skeletonize

    graph = build_graph(skeletonize(skel_img))
    grey = np.zeros(skel_img.shape, np.uint8)
    sm = StereoMasks(skel_img, skel_img, grey, grey, ridge_radius_map(skel_img), (100.0, 300.0), 1450.0)
    placer = EndPlacer(graph, sm, {}, load_config().localize.match)
    nodes = np.flatnonzero(graph.node_kind == JUNCTION).tolist()
    return placer, sorted(nodes, key=lambda n: placer.node_xy[n][0])


def _split_y():
    """A Y whose junction is split in two: the parent's left piece ends at (100, 100), its right piece and the child
    leave from (102, 100), the two joined by two one-point pieces (above and below (101, 100))."""
    import cv2

    m = np.zeros((200, 200), np.uint8)
    cv2.line(m, (10, 100), (99, 100), 255, 1)
    m[99, 101] = m[101, 101] = m[100, 100] = m[100, 102] = 255
    cv2.line(m, (103, 99), (160, 42), 255, 1)
    cv2.line(m, (103, 101), (160, 158), 255, 1)
    return _placer_over(m)


def _two_children(link_px: int):
    """A line along the rows, a piece leaving it up-left from ``x = 100 - link_px`` and one downwards from ``x = 100``:
    two junctions ``link_px`` apart, four pieces besides the one between them."""
    import cv2

    m = np.zeros((200, 200), np.uint8)
    cv2.line(m, (10, 100), (190, 100), 255, 1)
    cv2.line(m, (100 - link_px, 100), (40 - link_px, 30), 255, 1)
    cv2.line(m, (100, 100), (100, 180), 255, 1)
    return _placer_over(m)


def test_a_y_whose_junction_is_split_by_one_point_pieces_is_taken_with_its_partner_once():
    # (SPLIT_JUNCTION: seeds 1006 T7 and 1018 T10, exact masks, were not placed: one junction of the pair had one
    # usable piece, the other two, the one-point pieces between them none)
    placer, (a, b) = _split_y()
    links = set(placer.incident[a]) & set(placer.incident[b])
    assert links and all(len(placer.g.seg_yx[s]) == 1 for s in links)
    usable = [sum(placer._usable(s) for s in placer.incident[n]) for n in (a, b)]
    assert sorted(usable) == [1, 2]
    lo, hi = min(a, b), max(a, b)
    assert placer._split_partner(lo) == hi          # the pair's lower node takes the pair's pieces
    assert placer._split_partner(hi) is None        # ... the other places nothing: one fork per pair


@pytest.mark.parametrize("link_px", [1, 2])
def test_a_pair_of_junctions_with_four_pieces_or_two_points_apart_is_not_one_fork(link_px):
    # four pieces (a crossing, or a fork beside one: on the 60 scenes such pairs placed false forks), or a piece of two
    # points between them (each junction has its three)
    placer, (a, b) = _two_children(link_px)
    link = set(placer.incident[a]) & set(placer.incident[b])
    assert len(link) == 1 and len(placer.g.seg_yx[link.pop()]) == link_px
    assert placer._split_partner(min(a, b)) is None and placer._split_partner(max(a, b)) is None


def _thick_split_y(stray_px: float | None):
    """A drawn Y (parent 9 px thick along the rows, a child 5 px thick leaving it up-right at 45 deg from (100, 100))
    as both views' mask, its skeleton the Y's junction split in two by one-point pieces (as ``_split_y``), and where
    ``stray_px`` is given a piece of another branch (skeleton and silhouette) ending that far below the fork."""
    import cv2

    from appliance.config import load_config
    from appliance.localize.ends import EndPlacer
    from appliance.localize.graph import JUNCTION, build_graph
    from appliance.localize.matching import StereoMasks
    from appliance.localize.radius import ridge_radius_map
    from appliance.localize.skeleton import skeletonize

    mask = np.zeros((200, 200), np.uint8)
    cv2.line(mask, (10, 100), (190, 100), 255, 9)
    cv2.line(mask, (100, 100), (160, 40), 255, 5)
    sk = np.zeros((200, 200), np.uint8)
    cv2.line(sk, (10, 100), (99, 100), 255, 1)
    sk[99, 101] = sk[101, 101] = sk[100, 100] = sk[100, 102] = 255
    cv2.line(sk, (103, 100), (190, 100), 255, 1)
    cv2.line(sk, (103, 99), (160, 42), 255, 1)
    if stray_px is not None:          # (steep, 3 px thick, below the parent, ending short of it: no junction with the Y)
        y = int(round(100 + stray_px))
        cv2.line(mask, (100, y), (100, 190), 255, 3)
        cv2.line(sk, (100, y), (100, 190), 255, 1)
    graph = build_graph(skeletonize(sk))
    grey = np.zeros(mask.shape, np.uint8)
    sm = StereoMasks(mask, mask, grey, grey, ridge_radius_map(mask), (100.0, 300.0), 1450.0)
    placer = EndPlacer(graph, sm, {}, load_config().localize.match)
    nodes = sorted(np.flatnonzero(graph.node_kind == JUNCTION).tolist())
    return placer, nodes


@pytest.mark.parametrize("stray_px", [None, 9.0, 40.0])
def test_a_split_pair_stands_where_both_nodes_outline_places_agree_and_no_other_branch_lies_over_it(monkeypatch,
                                                                                                    stray_px):
    # (SPLIT_CHECKED: seed 615 T10, colour masks, a split pair under a branch crossing it, was placed 69 mm off from
    # the crossing branch's disparity; pairs whose two nodes' outline places disagree were placed 5-17 px off)
    from appliance.localize import forkends

    placer, nodes = _thick_split_y(stray_px)
    pairs = [(n, placer._split_partner(n)) for n in nodes if placer._split_partner(n) is not None]
    assert len(pairs) == 1
    a, b = pairs[0]
    segs = sorted({s for n in (a, b) for s in placer.incident[n] if placer._usable(s)})
    assert len(segs) == 3
    hits = [placer._outline_place_from(segs, placer.node_xy[n], placer._node_radius(n)) for n in (a, b)]
    places = [q for q, _ in hits]
    assert all(q is not None for q in places)
    assert np.hypot(*(places[0] - places[1])) <= 4.0            # the two nodes' places agree ...
    assert all(np.hypot(*(q - (100.0, 100.0))) < 8.0 for q in places)   # ... near the drawn fork
    # both nodes lie on the parent's axis (deep inside it, as seed 643 T5's pair): not placed ...
    assert max(off for _, off in hits) < forkends.SPLIT_OFF_AXIS
    assert placer._split_pair_place(a, b, segs) is None
    # ... without that check, placed where no other branch lies over the place
    monkeypatch.setattr(forkends, "SPLIT_OFF_AXIS", 0.0)
    xy = placer._split_pair_place(a, b, segs)
    assert (xy is not None) is (stray_px is None or stray_px > 20.0)     # a branch over the place: not placed
    assert xy is None or np.allclose(xy, 0.5 * (places[0] + places[1]))
