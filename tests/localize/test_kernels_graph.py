"""The rectification's and the graph stages' kernels (localize/kernels_graph.py, speedR) against the code
they replace (kept here as the reference)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from tests.localize.test_rectify import distorted_rig

from appliance.localize import kernels_graph
from appliance.localize.rectify import Rectifier
from appliance.localize.skeleton import block_mean


def needed_tiles_reference(rect: Rectifier, image: np.ndarray, side: int) -> np.ndarray:
    """Rectifier._needed_tiles before speedR: 8 px cells by an OpenCV block mean, tiles by an integral image."""
    b = rect.BLOCK_PX
    h, w = image.shape
    hb, wb = -(-h // b), -(-w // b)
    any_px = cv2.threshold(image, 0, 255, cv2.THRESH_BINARY)[1]
    if (hb * b, wb * b) != (h, w):
        any_px = cv2.copyMakeBorder(any_px, 0, hb * b - h, 0, wb * b - w, cv2.BORDER_CONSTANT, value=0)
    cells = cv2.integral(block_mean(any_px, b))
    t = rect.tiles[side]
    by0, bx0 = t[:, 4] // b, t[:, 6] // b
    by1, bx1 = np.maximum(-(-t[:, 5] // b), by0), np.maximum(-(-t[:, 7] // b), bx0)
    count = cells[by1, bx1] - cells[by0, bx1] - cells[by1, bx0] + cells[by0, bx0]
    need = t[count > 0, :4]
    if len(need) == 0:
        return need
    start = np.flatnonzero(np.concatenate([[True], (need[1:, 0] != need[:-1, 0]) | (need[1:, 2] != need[:-1, 3])]))
    end = np.concatenate([start[1:], [len(need)]]) - 1
    return np.column_stack([need[start, :3], need[end, 3]])


@pytest.mark.parametrize("size", [(320, 240), (336, 251)])
def test_needed_tiles_are_the_block_mean_tiles(size):
    w, h = size                                         # (251 rows: a last cell row of 3 px)
    rect = Rectifier.from_calibration(distorted_rig(w, h))
    rng = np.random.default_rng(11)
    masks = [np.zeros((h, w), np.uint8), np.full((h, w), 255, np.uint8)]
    for k in range(40):
        m = np.zeros((h, w), np.uint8)
        for _ in range(k % 5):
            cv2.line(m, tuple(int(v) for v in rng.integers(0, (w, h))), tuple(int(v) for v in rng.integers(0, (w, h))),
                     255, int(rng.integers(1, 12)))
        ys, xs = rng.integers(0, h, k), rng.integers(0, w, k)
        m[ys, xs] = rng.integers(1, 256, k)                 # single (faint) pixels anywhere, the corners too
        m[[0, h - 1][k % 2], [0, w - 1][(k // 2) % 2]] = k % 3
        masks.append(m)
    for m in masks:
        for side in (0, 1):
            got = rect._needed_tiles(m, side)
            assert got.dtype == np.int64 and got.shape[1] == 4
            np.testing.assert_array_equal(got, needed_tiles_reference(rect, m, side))
    # a view (not C-contiguous) takes the numpy path, with the same runs
    wide = np.zeros((h, 2 * w), np.uint8)
    wide[:, :w] = masks[5]
    np.testing.assert_array_equal(rect._needed_tiles(wide[:, :w], 0), needed_tiles_reference(rect, masks[5], 0))


def test_needed_tiles_kernel_joins_runs_of_one_tile_row_only():
    # four tiles in a 2 x 2 grid, each reading its own cell; cells 0, 1 and 3 set
    words = np.zeros((16, 2), np.uint64)
    words[0, 0], words[3, 1], words[12, 1] = 1, 1 << 63, 5
    cells = np.array([[0, 1, 0, 1], [0, 1, 1, 2], [1, 2, 0, 1], [1, 2, 1, 2]], np.int64)
    tiles = np.array([[0, 4, 0, 4], [0, 4, 4, 8], [4, 8, 0, 4], [4, 8, 4, 8]], np.int64)
    out = np.zeros((4, 4), np.int64)
    n = kernels_graph.needed_tiles(words, cells, tiles, out)
    np.testing.assert_array_equal(out[:n], [[0, 4, 0, 8], [4, 8, 4, 8]])
    empty = cells.copy()
    empty[:, 1] = empty[:, 0]                               # no source cells: never needed
    assert kernels_graph.needed_tiles(words, empty, tiles, out) == 0


def build_graph_reference(skel):
    """graph.build_graph before speedR: kernels_graph.graph_core and numpy glue."""
    from appliance.localize.graph import ENDPOINT, JUNCTION, SkeletonGraph, _group
    from appliance.localize.skeleton import SparseImage, neighbour_tables
    img = SparseImage.from_image(skel.image)
    h, w = img.shape
    idx = np.flatnonzero(img.flat.view(bool))
    yx = np.empty((len(idx), 2), np.int64)
    yx[:, 0], yx[:, 1] = np.divmod(idx, w + 2)
    yx -= 1
    count, _, _ = neighbour_tables()
    n, jlab, n_j, slab, n_s, sn, nn, steps = kernels_graph.graph_core(img.flat, idx, w + 2, w, count)
    jm, em, pm = n >= 3, n == 1, n == 2
    jyx, eyx, pyx = yx[jm], yx[em], yx[pm]
    jlab, slab = jlab[jm], slab[pm]
    node_pixels = _group(jlab, jyx, n_j) + list(eyx[:, None, :])
    n_nodes = len(node_pixels)
    node_of = np.concatenate([jlab, n_j + 1 + np.arange(len(eyx))])
    node_yx = np.zeros((n_nodes, 2))
    if n_nodes:
        nyx = np.concatenate([jyx, eyx])
        size = np.bincount(node_of, minlength=n_nodes + 1)[1:]
        for c in (0, 1):
            node_yx[:, c] = np.bincount(node_of, weights=nyx[:, c], minlength=n_nodes + 1)[1:] / size
    node_kind = np.concatenate([np.full(n_j, JUNCTION), np.full(len(eyx), ENDPOINT)]).astype(int)
    seg_yx = _group(slab, pyx, n_s)
    length = np.zeros(n_s + 1)
    for k in range(4):
        length += (np.sqrt(2) if k in (1, 3) else 1.0) * steps[k]
    sn, nn = sn - 1, nn - 1
    ends = np.full((n_s, 2), -1)
    first = np.searchsorted(sn[:, 0], sn[:, 0])
    rank = np.arange(len(sn)) - first
    two = rank < 2
    ends[sn[two, 0], rank[two]] = sn[two, 1]
    filled = np.minimum(np.bincount(sn[:, 0], minlength=n_s), 2)
    length = length[1:] + filled
    seg_nodes = np.vstack([ends, nn]).astype(int) if len(nn) else ends
    seg_yx = seg_yx + [np.zeros((0, 2), int)] * len(nn)
    length = np.concatenate([length, np.ones(len(nn))]) * skel.scale
    return SkeletonGraph(img.shape, skel.scale, node_yx, node_kind, node_pixels, seg_nodes.reshape(-1, 2),
                         seg_yx, length)


def assert_same_graph(a, b):
    assert a.shape == b.shape and a.scale == b.scale
    for f in ("node_yx", "node_kind", "seg_nodes", "seg_length_px", "seg_recovered"):
        x, y = getattr(a, f), getattr(b, f)
        assert x.dtype == y.dtype and x.shape == y.shape, f
        np.testing.assert_array_equal(x, y, err_msg=f)        # (bit for bit: centroids and lengths too)
    for f in ("node_pixels", "seg_yx"):
        x, y = getattr(a, f), getattr(b, f)
        assert len(x) == len(y), f
        for p, q in zip(x, y):
            assert p.dtype == q.dtype and p.shape == q.shape, f
            np.testing.assert_array_equal(p, q, err_msg=f)


def test_build_graph_is_the_numpy_glue_graph():
    """Random images (any width, also multiples of 8; sparse to dense; bool, 0/255 and views), their thinned
    skeletons, constructed shapes and a fixture's pruned skeleton: every array of the graph the same."""
    from appliance.localize.graph import build_graph
    from appliance.localize.skeleton import Skeleton, skeletonize

    rng = np.random.default_rng(17)
    cases = [Skeleton(np.zeros((5, 9), np.uint8)), Skeleton(np.ones((1, 1), np.uint8)),
             Skeleton(np.eye(16, dtype=np.uint8)), Skeleton(np.eye(16, dtype=np.uint8)[::-1], 4)]
    for k in range(50):
        h, w = int(rng.integers(1, 50)), int(rng.choice([rng.integers(1, 60), 8 * rng.integers(1, 7)]))
        img = (rng.random((h, w)) < rng.uniform(0.02, 0.6)).astype(np.uint8)
        cases.append(Skeleton(img * (255 if k % 3 == 0 else 1), int(rng.integers(1, 5))))
        cases.append(skeletonize(img * 255, "thinning"))
        if k % 4 == 0:
            cases.append(Skeleton(img.astype(bool), 2))
            cases.append(Skeleton(np.pad(img, ((0, 0), (3, 5)))[:, 3:-5], 1))     # a view: not contiguous
    mask = np.zeros((240, 320), np.uint8)
    for a, b, t in (((10, 200), (300, 20), 9), ((150, 110), (160, 235), 5), ((40, 30), (90, 120), 3)):
        cv2.line(mask, a, b, 255, t)
    cases.append(skeletonize(mask, "fast", 4))
    for skel in cases:
        assert_same_graph(build_graph(skel), build_graph_reference(skel))


def end_geometry_reference(graph, radius_map, reach_px=20.0):
    """recover.end_geometry before speedR (numpy: every (end, pixel) pair, np.bincount sums)."""
    from appliance.localize.graph import ENDPOINT
    from appliance.localize.radius import radius_at
    from appliance.localize.recover import EndGeometry
    ends = graph.seg_nodes.ravel()
    seg = np.repeat(np.arange(len(graph.seg_nodes)), 2)
    is_end = ends >= 0
    is_end[is_end] = graph.node_kind[ends[is_end]] == ENDPOINT
    ends, seg = ends[is_end], seg[is_end]
    n_px = np.array([len(p) for p in graph.seg_yx], int)
    if len(ends) == 0 or n_px[seg].sum() == 0:
        return EndGeometry(np.zeros(0, int), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, int))
    all_px = graph.to_full(np.concatenate([p for p in graph.seg_yx if len(p)]))
    first = np.r_[0, np.cumsum(n_px)[:-1]]
    owner = np.repeat(np.arange(len(ends)), n_px[seg])
    at = np.arange(len(owner)) - np.repeat(np.cumsum(n_px[seg]) - n_px[seg], n_px[seg]) + first[seg][owner]
    p = graph.to_full(graph.node_yx[ends])
    pts = all_px[at]
    near = np.hypot(*(pts - p[owner]).T) <= reach_px
    owner, pts = owner[near], pts[near]
    count = np.bincount(owner, minlength=len(ends))
    c = np.column_stack([np.bincount(owner, pts[:, k], len(ends)) for k in (0, 1)]) / np.maximum(count, 1)[:, None]
    d = pts - c[owner]
    sxx, sxy, syy = (np.bincount(owner, u * v, len(ends)) for u, v in ((d[:, 0], d[:, 0]), (d[:, 0], d[:, 1]),
                                                                        (d[:, 1], d[:, 1])))
    big = (sxx + syy) / 2 + np.hypot((sxx - syy) / 2, sxy)
    axis = np.where((sxx >= syy)[:, None], np.column_stack([big - syy, sxy]), np.column_stack([sxy, big - sxx]))
    axis /= np.maximum(np.hypot(axis[:, 0], axis[:, 1]), 1e-300)[:, None]
    axis *= np.where(np.einsum("ij,ij->i", axis, p - c) >= 0, 1.0, -1.0)[:, None]
    ok = count >= 2
    xy = p[ok]
    return EndGeometry(ends[ok], xy, axis[ok], radius_at(radius_map, xy), seg[ok])


def test_end_geometry_is_the_numpy_fit():
    """Random branch masks at scales 1 and 4, with recovered (pixel-less) segments and loops: every end's
    node, position, axis, radius and segment the same, bit for bit."""
    from appliance.localize.graph import build_graph
    from appliance.localize.radius import ridge_radius_map
    from appliance.localize.recover import end_geometry
    from appliance.localize.skeleton import skeletonize

    rng = np.random.default_rng(23)
    n_ends = 0
    for k in range(40):
        mask = np.zeros((120, 160), np.uint8)
        for _ in range(int(rng.integers(1, 6))):
            a, b = rng.integers(0, (160, 120)), rng.integers(0, (160, 120))
            cv2.line(mask, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), 255, int(rng.integers(2, 14)))
        if k % 5 == 0:
            cv2.circle(mask, (80, 60), 30, 255, 4)                      # a loop
        skel = skeletonize(mask, "fast" if k % 2 else "thinning", 4)
        graph = build_graph(skel)
        if k % 4 == 0 and len(graph.node_kind) >= 2:
            graph = graph.with_segments(np.array([[0, 1]]), [np.zeros((0, 2), np.int64)], np.array([3.0]), [])
        rmap = ridge_radius_map(skel.mask, 3, skel.scale) if skel.scale > 1 else ridge_radius_map(mask)
        for reach in (20.0, 6.0):
            a, b = end_geometry(graph, rmap, reach), end_geometry_reference(graph, rmap, reach)
            for f in ("node", "xy_px", "dir", "radius_px", "segment"):
                x, y = getattr(a, f), getattr(b, f)
                assert x.dtype == y.dtype and x.shape == y.shape, f
                np.testing.assert_array_equal(x, y, err_msg=f)
            n_ends += len(a.node)
    assert n_ends > 100


def test_line_pixels_kernel_is_np_unique_of_the_linspace_points():
    """All lines of a bridge at once: each line's pixels are np.unique of its rounded np.linspace points
    (lines of one point, axis-parallel, diagonal, backwards, half-pixel ends), at scales 1, 2 and 4."""
    rng = np.random.default_rng(29)
    for scale in (1.0, 2.0, 4.0):
        a = rng.uniform(-3, 400, (300, 2))
        b = a + rng.normal(0, 40, (300, 2)) * rng.choice([0.0, 0.1, 1.0], (300, 1))
        b[::7, 0] = a[::7, 0]                                          # vertical
        b[::11] = a[::11] + rng.integers(-9, 9, (1, 1)) * scale       # diagonal
        a[::13] = np.round(a[::13]) + 0.5                              # rounding ties
        px, start = kernels_graph.line_pixels(a, b, scale)
        assert start[0] == 0 and start[-1] == len(px) and px.dtype == np.int64
        for i in range(len(a)):
            pa, pb = (a[i] + 0.5) / scale - 0.5, (b[i] + 0.5) / scale - 0.5
            n = int(np.ceil(np.abs(pb - pa).max())) + 1
            want = np.unique(np.rint(pa + np.linspace(0, 1, n)[:, None] * (pb - pa)).astype(int)[:, ::-1], axis=0)
            np.testing.assert_array_equal(px[start[i]:start[i + 1]], want)
    px, start = kernels_graph.line_pixels(np.zeros((0, 2)), np.zeros((0, 2)), 4.0)
    assert px.shape == (0, 2) and start.tolist() == [0]


def test_prune_of_a_ring_with_one_spur_leaves_the_ring():
    """(Found by the end-fit test: once the spur went, the ring has no node left, and spur_ids indexed the
    empty node table.)"""
    from appliance.localize.prune import prune
    from appliance.localize.skeleton import skeletonize

    mask = np.zeros((120, 160), np.uint8)
    cv2.circle(mask, (80, 60), 30, 255, 4)
    cv2.line(mask, (110, 60), (114, 60), 255, 2)
    skel, graph = prune(skeletonize(mask, "thinning"), 8.0)
    assert len(graph.node_kind) == 0 and len(graph.seg_yx) == 1 and graph.seg_length_px[0] > 150


def test_coarse_mask_is_the_threshold_block_mean_and_threshold():
    """All 2^16 patterns of a 4 x 4 block (coverage values either side of 128 drawn at random), and
    skeletonize(coverage, level=127) against the threshold at 127 then skeletonize, on line masks."""
    from appliance.localize.skeleton import binary, skeletonize

    k = np.arange(1 << 16)
    bits = (k[:, None] >> np.arange(16)) & 1
    rng = np.random.default_rng(31)
    for _ in range(2):
        vals = np.where(bits, rng.integers(128, 256, bits.shape), rng.integers(0, 128, bits.shape)).astype(np.uint8)
        img = np.ascontiguousarray(np.tile(vals.reshape(-1, 4, 4).transpose(1, 0, 2).reshape(4, -1), (2, 1)))
        want = cv2.threshold(block_mean(binary(cv2.threshold(img, 127, 255, cv2.THRESH_BINARY)[1], 255), 4), 76, 255,
                             cv2.THRESH_BINARY)[1]
        got = kernels_graph.coarse_mask(img.view(np.uint64), np.empty(want.shape, np.uint8))
        np.testing.assert_array_equal(got, want)
        assert (got[0] == 255).sum() == (bits.sum(1) >= 5).sum()
    for shape in ((240, 320), (96, 136), (100, 130)):          # (the last: the numpy path)
        cov = np.zeros(shape, np.uint8)
        for _ in range(4):
            a, b = rng.integers(0, shape[::-1], 2), rng.integers(0, shape[::-1], 2)
            cv2.line(cov, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), int(rng.integers(100, 256)), int(rng.integers(1, 15)))
        cov = cv2.GaussianBlur(cov, (5, 5), 1.5)                 # soft edges: values either side of 128
        for method in ("fast", "thinning"):
            a = skeletonize(cov, method, 4, level=127)
            b = skeletonize(cv2.threshold(cov, 127, 255, cv2.THRESH_BINARY)[1], method, 4)
            assert a.scale == b.scale
            np.testing.assert_array_equal(a.image, b.image)
            np.testing.assert_array_equal(a.mask, b.mask)


def test_group_medians_are_np_median_of_each_group():
    rng = np.random.default_rng(37)
    sizes = np.r_[0, 1, 2, 3, rng.integers(0, 300, 200)]
    values = rng.normal(900, 200, sizes.sum())
    values[::17] = np.round(values[::17])                      # ties
    start = np.r_[0, np.cumsum(sizes)].astype(np.int64)
    got = kernels_graph.group_medians(values, start)
    for g, (a, b) in enumerate(zip(start[:-1], start[1:])):
        if b == a:
            assert np.isnan(got[g])
        else:
            assert got[g] == np.median(values[a:b])               # bit for bit


def test_thin_is_zhang_suen_then_remove_corners():
    """Random masks (blobs, lines, noise; widths not a multiple of 8; views; bool), pixels on the image's
    border included: the same 0/1 skeleton as the two numpy-glued passes."""
    from appliance.localize.skeleton import remove_corners, thin, zhang_suen

    rng = np.random.default_rng(41)
    for k in range(60):
        h, w = int(rng.integers(3, 90)), int(rng.integers(3, 130))
        m = np.zeros((h, w), np.uint8)
        for _ in range(int(rng.integers(1, 6))):
            a, b = rng.integers(0, (w, h), 2), rng.integers(0, (w, h), 2)
            cv2.line(m, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), 255, int(rng.integers(1, 12)))
        if k % 3 == 0:
            m[rng.random((h, w)) < 0.1] = 255
        if k % 5 == 0:
            m[:, :3] = 255                                      # along the border
        mask = m if k % 4 else np.pad(m, 2)[2:-2, 2:-2]         # (a view)
        want = remove_corners(zhang_suen(m))
        got = thin(mask)
        assert got.dtype == np.uint8 and got.shape == m.shape
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(thin(m > 0), want)            # (bool: the numpy path)


def spur_ids_reference(graph, min_length_px, radius_factor=0.0, radius_map=None, keep_border=False):
    """prune.spur_ids before speedR (numpy)."""
    from appliance.localize.graph import ENDPOINT, JUNCTION
    from appliance.localize.radius import radius_at
    ends = graph.seg_nodes
    kind = np.where(ends >= 0, graph.node_kind[np.maximum(ends, 0)], 0)
    spur = ((kind[:, 0] == ENDPOINT) & (kind[:, 1] == JUNCTION)) | ((kind[:, 1] == ENDPOINT) & (kind[:, 0] == JUNCTION))
    if not spur.any():
        return np.zeros(0, int)
    junction = np.where(kind[:, 0] == JUNCTION, ends[:, 0], ends[:, 1])
    if keep_border:
        end = np.where(kind[:, 0] == ENDPOINT, ends[:, 0], ends[:, 1])
        y, x = graph.node_yx[np.maximum(end, 0)].T
        h, w = graph.shape
        out = spur & ((np.minimum(y, x) <= 1) | (y >= h - 2) | (x >= w - 2))
        n_out = np.bincount(junction[out], minlength=len(graph.node_kind))
        spur &= ~(out & (n_out[np.maximum(junction, 0)] == 1))
    limit = np.full(len(ends), float(min_length_px))
    if radius_factor > 0 and radius_map is not None:
        r = radius_at(radius_map, graph.to_full(graph.node_yx[np.maximum(junction, 0)]))
        limit = np.maximum(limit, radius_factor * r)
    return np.flatnonzero(spur & (graph.seg_length_px < limit))


def test_spur_ids_are_the_numpy_test():
    """Random branch masks with bumps, cut by the image's edges, at scales 1 and 4; minimum lengths and
    radius factors either side of the spurs' lengths; RadiusMap, plain and float64 radius maps."""
    from appliance.localize.graph import build_graph
    from appliance.localize.prune import spur_ids
    from appliance.localize.radius import RadiusMap, ridge_radius_map
    from appliance.localize.skeleton import skeletonize

    rng = np.random.default_rng(43)
    found = 0
    for k in range(40):
        mask = np.zeros((120, 160), np.uint8)
        for _ in range(int(rng.integers(2, 7))):
            a, b = rng.integers(-20, (180, 140)), rng.integers(0, (160, 120))
            cv2.line(mask, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), 255, int(rng.integers(2, 16)))
        skel = skeletonize(mask, "fast" if k % 2 else "thinning", 4)
        graph = build_graph(skel)
        rmap = ridge_radius_map(skel.mask, 3, skel.scale) if skel.scale > 1 else ridge_radius_map(mask)
        for radius_map in (rmap, rmap.image if skel.scale == 1 else rmap, RadiusMap(rmap.image.astype(np.float64), rmap.scale)):
            for min_len, factor, border in ((5.0, 0.0, False), (12.0, 1.5, True), (8.0, 3.0, False), (30.0, 1.0, True)):
                want = spur_ids_reference(graph, min_len, factor, radius_map, border)
                got = spur_ids(graph, min_len, factor, radius_map, border)
                np.testing.assert_array_equal(got, want)
                found += len(want)
        assert len(spur_ids(graph, 5.0, 1.5, None)) == len(spur_ids_reference(graph, 5.0, 1.5, None))
    assert found > 100


def test_corners_kernel_is_the_numpy_glued_corner_removal():
    """remove_corners of uint8 images (the kernel) against the same images as bool (the numpy-glued path):
    random thin patterns, staircases and bumps, widths not a multiple of 8, values other than 1."""
    from appliance.localize.skeleton import remove_corners

    rng = np.random.default_rng(47)
    for k in range(60):
        h, w = int(rng.integers(2, 60)), int(rng.integers(2, 90))
        img = (rng.random((h, w)) < rng.uniform(0.05, 0.5)).astype(np.uint8)
        img *= np.uint8(1 if k % 2 else 255)
        got = remove_corners(img)
        want = remove_corners(img > 0)
        assert got.dtype == np.uint8 and got.shape == img.shape
        np.testing.assert_array_equal(got, want)
    stair = np.zeros((8, 16), np.uint8)
    for i in range(6):
        stair[i + 1, i + 1:i + 3] = 1                          # a 4-connected staircase: its corners go
    assert remove_corners(stair).sum() < stair.sum()


def test_source_box_is_the_grids_min_and_max():
    """LazyRectified's union of tile source boxes: the numpy min / max over the grids' tiles it replaced, on a
    rig's grids (empty tiles: start W + H, end -1) and on random ones."""
    rect = Rectifier.from_calibration(distorted_rig(333, 251))
    rng = np.random.default_rng(53)
    grids = [rect.source_grid(0, (16, 64)), rect.source_grid(1, (16, 64))]
    grids.append((rng.integers(0, 500, (9, 7, 2)), rng.integers(-1, 500, (9, 7, 2))))
    for lo, hi in grids:
        rows, cols = lo.shape[:2]
        for _ in range(200):
            i0, j0 = int(rng.integers(0, rows)), int(rng.integers(0, cols))
            i1, j1 = int(rng.integers(i0 + 1, rows + 1)), int(rng.integers(j0 + 1, cols + 1))
            sy0, sx0 = lo[i0:i1, j0:j1].reshape(-1, 2).min(0).tolist()
            sy1, sx1 = hi[i0:i1, j0:j1].reshape(-1, 2).max(0).tolist()
            assert kernels_graph.source_box(lo, hi, i0, i1, j0, j1) == (sy0, sy1, sx0, sx1)


def test_project_distorted_is_cv2_project_points_bit_for_bit():
    """Random rays in front of the camera (wide angles too), distortion models of 4, 5, 8 and 12
    coefficients; and Rectifier.to_original on a distorted rig against its projectPoints path."""
    rng = np.random.default_rng(59)
    K = np.array([[1450.3, 0, 641.7], [0, 1449.1, 478.2], [0, 0, 1]])
    rays = np.column_stack([rng.uniform(-0.6, 0.6, (500, 2)), rng.uniform(0.5, 2.0, 500)])
    for n in (4, 5, 8, 12):
        D = rng.normal(0, 0.05, n)
        k = np.zeros(12)
        k[:n] = D
        want = cv2.projectPoints(rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)[0].reshape(-1, 2)
        got = kernels_graph.project_distorted(rays, K, k, np.empty((len(rays), 2)))
        np.testing.assert_array_equal(got, want)
    rect = Rectifier.from_calibration(distorted_rig(333, 251))
    pts = rng.uniform(-20, 350, (300, 2))
    for side in (0, 1):
        c = rect.calib
        P, Rr, K, D = (c.P1, c.R1, c.K1, c.D1) if side == 0 else (c.P2, c.R2, c.K2, c.D2)
        rays = np.column_stack([(pts[:, 0] - P[0, 2]) / P[0, 0], (pts[:, 1] - P[1, 2]) / P[1, 1], np.ones(len(pts))]) @ Rr
        want = cv2.projectPoints(rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)[0].reshape(-1, 2)
        np.testing.assert_array_equal(rect.to_original(pts, side), want)
        assert rect.to_original(pts[:0], side).shape == (0, 2)


def recover_collinear_reference(graph, cfg, radius_map, occluded=None):
    """recover.recover_collinear before speedR (the candidates from numpy (E, E) matrices)."""
    from appliance.localize.recover import _bridge, _covered_many, end_geometry
    ends = end_geometry(graph, radius_map)
    if len(ends.node) < 2:
        return graph
    gap = ends.xy_px[None, :, :] - ends.xy_px[:, None, :]
    dist = np.hypot(gap[..., 0], gap[..., 1])
    unit = gap / np.maximum(dist, 1e-9)[..., None]
    cos_i = np.einsum("ik,ijk->ij", ends.dir, unit)
    cos_j = -np.einsum("jk,ijk->ij", ends.dir, unit)
    r = np.maximum(ends.radius_px, 0.5)
    ratio = np.maximum(r[:, None], r[None, :]) / np.minimum(r[:, None], r[None, :])
    cos_max = np.cos(np.radians(cfg.max_angle_deg))
    ok = (cos_i >= cos_max) & (cos_j >= cos_max) & (dist <= cfg.max_gap_px) & (ratio <= cfg.max_radius_ratio)
    ok &= ends.segment[:, None] != ends.segment[None, :]
    ok = np.triu(ok, 1)
    cost = (np.arccos(np.clip(cos_i, -1, 1)) + np.arccos(np.clip(cos_j, -1, 1))) + dist / max(cfg.max_gap_px, 1)
    used, pairs = set(), []
    cand = sorted(zip(cost[ok], *np.nonzero(ok)))
    long_gap = [(i, j) for _, i, j in cand if dist[i, j] > 4 * (r[i] + r[j]) / 2]
    cover = dict(zip(long_gap, _covered_many(occluded, [(ends.xy_px[i], ends.xy_px[j]) for i, j in long_gap])))
    for _, i, j in cand:
        if i in used or j in used:
            continue
        if cover.get((i, j), 1.0) < 0.5:
            continue
        used.update((i, j))
        pairs.append((int(i), int(j)))
    return _bridge(graph, ends, pairs)


def test_recover_collinear_is_the_numpy_matrices_recovery():
    """Branches cut by gaps (some under an 'occluder' half plane), at several angle, gap and ratio limits:
    the same bridges (every array of the graph), bridges made in most cases."""
    from dataclasses import replace

    from appliance.commands.common import effective_config
    from appliance.localize.graph import build_graph
    from appliance.localize.radius import ridge_radius_map
    from appliance.localize.recover import recover_collinear
    from appliance.localize.skeleton import skeletonize

    base = effective_config(None).localize.recover
    rng = np.random.default_rng(61)
    bridged = 0
    for k in range(30):
        mask = np.zeros((240, 320), np.uint8)
        cuts = []
        for _ in range(int(rng.integers(1, 4))):
            a, b = rng.integers(0, (320, 240)), rng.integers(0, (320, 240))
            cv2.line(mask, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), 255, int(rng.integers(3, 14)))
            cuts += [a + t * (b - a) for t in rng.uniform(0.2, 0.8, int(rng.integers(1, 3)))]
        for c in cuts:                                               # gaps across the lines
            cv2.circle(mask, (int(c[0]), int(c[1])), int(rng.integers(4, 25)), 0, -1)
        skel = skeletonize(mask, "fast", 4)
        graph = build_graph(skel)
        rmap = ridge_radius_map(skel.mask, 3, skel.scale)
        cfg = replace(base, max_angle_deg=float(rng.choice([10.0, 25.0, 45.0])),
                      max_gap_px=float(rng.choice([30.0, 80.0, 200.0])), max_radius_ratio=float(rng.choice([1.5, 3.0])))
        for occluded in (None, lambda xy: xy[:, 0] > 160):
            a, b = recover_collinear(graph, cfg, rmap, occluded), recover_collinear_reference(graph, cfg, rmap, occluded)
            assert_same_graph(a, b)
            bridged += int(a.seg_recovered.sum())
    assert bridged > 10


def _zhang_suen_numpy(mask):
    """The numpy thinning the kernel replaced (every sub-iteration over all pixels, all at once)."""
    from appliance.localize.skeleton import SparseImage, zhang_suen_tables
    tables = zhang_suen_tables()
    img = SparseImage.from_image(mask)
    h, w = img.shape
    inner = np.zeros((h + 2, w + 2), bool)
    inner[2:h, 2:w] = True                       # (pixels on the image border stay)
    i, quiet = 0, 0
    while quiet < 2:
        idx = np.flatnonzero(img.flat.view(bool) & inner.reshape(-1))
        gone = idx[tables[i & 1][img.codes(idx)]]
        img.flat[gone] = 0
        quiet = 0 if len(gone) else quiet + 1
        i += 1
    return img.image()


def _remove_corners_numpy(skel01):
    """The numpy corner removal the kernel replaced (two passes by parity, each all at once)."""
    from appliance.localize.skeleton import SparseImage, neighbour_tables
    corner = neighbour_tables()[2]
    img = SparseImage.from_image(skel01)
    idx = np.flatnonzero(img.flat.view(bool))
    parity = (idx // (img.shape[1] + 2) + idx % (img.shape[1] + 2)) & 1
    for p in (0, 1):
        at = idx[parity == p]
        img.flat[at[corner[img.codes(at)]]] = 0
    return img.image()


def test_thinning_and_corner_kernels_are_the_numpy_passes():
    """zhang_suen / remove_corners (compiled) give the numpy passes' images on random blobs and
    noise, and zhang_suen is still cv2.ximgproc.thinning where OpenCV's contrib module is there."""
    import cv2

    from appliance.localize.skeleton import remove_corners, zhang_suen
    rng = np.random.default_rng(5)
    thinning = getattr(getattr(cv2, "ximgproc", None), "thinning", None)
    for _ in range(120):
        h, w = rng.integers(3, 50, 2)
        m = (rng.random((h, w)) < rng.uniform(0.2, 0.95)).astype(np.uint8)
        m = cv2.dilate(m, np.ones((int(rng.integers(1, 4)),) * 2, np.uint8))
        thin = zhang_suen(m)
        np.testing.assert_array_equal(thin, _zhang_suen_numpy(m))
        if thinning is not None:
            np.testing.assert_array_equal(thin, thinning(m * 255) > 0)
        noise = (rng.random((h, w)) < 0.5).astype(np.uint8)
        for img in (thin, noise):
            np.testing.assert_array_equal(remove_corners(img), _remove_corners_numpy(img))
    assert zhang_suen(np.ones((9, 9), np.uint8))[4, 4] == 1 and remove_corners(np.eye(5, dtype=np.uint8)).sum() == 5


def _labels_numpy(shape: tuple[int, int], yx: np.ndarray) -> tuple[int, np.ndarray]:
    """8-connected components of a few pixels (N, 2): (count, label 1..count of each pixel)."""
    import cv2
    img = np.zeros(shape, np.uint8)
    img[yx[:, 0], yx[:, 1]] = 1
    n, lab = cv2.connectedComponents(img, connectivity=8, ltype=cv2.CV_32S)
    return n - 1, lab[yx[:, 0], yx[:, 1]]


def _unique_pairs_numpy(pairs: np.ndarray) -> np.ndarray:
    """Distinct rows of a (N, 2) array of non-negative ints, sorted."""
    if len(pairs) == 0:
        return pairs.reshape(0, 2)
    key = pairs[:, 0].astype(np.int64) << 32 | pairs[:, 1].astype(np.int64)
    key = np.unique(key)
    return np.column_stack([key >> 32, key & 0xFFFFFFFF])


def _build_graph_numpy(skel):
    """graph.build_graph before kernels_graph.graph_core (numpy and cv2.connectedComponents)."""
    from appliance.localize import graph as G
    from appliance.localize.skeleton import SparseImage, neighbour_tables
    from appliance.localize.graph import ENDPOINT, JUNCTION, SkeletonGraph
    img = SparseImage.from_image(skel.image)
    h, w = img.shape
    idx = np.flatnonzero(img.flat.view(bool))                # (0/1 bytes: a valid bool view) row-major
    yx = np.empty((len(idx), 2), np.int64)
    yx[:, 0], yx[:, 1] = np.divmod(idx, w + 2)
    yx -= 1
    count, _, _ = neighbour_tables()
    n = count[img.codes(idx)]
    jyx, eyx, pyx = yx[n >= 3], yx[n == 1], yx[n == 2]
    pidx = idx[n == 2]

    n_j, jlab = _labels_numpy(img.shape, jyx)
    node_pixels = G._group(jlab, jyx, n_j) + list(eyx[:, None, :])
    n_nodes = len(node_pixels)
    node_of = np.concatenate([jlab, n_j + 1 + np.arange(len(eyx))])     # 1-based node id of each node pixel
    node_yx = np.zeros((n_nodes, 2))
    if n_nodes:
        nyx = np.concatenate([jyx, eyx])                    # (2-D: np.vstack's)
        size = np.bincount(node_of, minlength=n_nodes + 1)[1:]
        for c in (0, 1):
            node_yx[:, c] = np.bincount(node_of, weights=nyx[:, c], minlength=n_nodes + 1)[1:] / size
    node_kind = np.concatenate([np.full(n_j, JUNCTION), np.full(len(eyx), ENDPOINT)]).astype(int)

    n_s, slab = _labels_numpy(img.shape, pyx)
    seg_yx = G._group(slab, pyx, n_s)

    # segment <-> node contacts, and node <-> node contacts (segments without pixels), looked up
    # at the skeleton pixels in flat, zero-padded id images, all 8 neighbours at once
    node_flat = np.zeros(img.flat.shape, np.int32)
    seg_flat = np.zeros(img.flat.shape, np.int32)
    nidx = np.concatenate([idx[n >= 3], idx[n == 1]])
    node_flat[nidx] = node_of
    seg_flat[pidx] = slab
    off = img.offsets()
    at = pidx[:, None] + off                                    # (P, 8)
    nb = node_flat.take(at)
    hit = nb > 0
    sn = np.column_stack([np.broadcast_to(slab[:, None], nb.shape)[hit], nb[hit]])
    nb = node_flat.take(nidx[:, None] + off)
    hit = (nb > 0) & (nb != node_of[:, None])
    nn = np.sort(np.column_stack([np.broadcast_to(node_of[:, None], nb.shape)[hit], nb[hit]]), axis=1)
    # E, SE, S, SW: each step along a segment counted once; added direction by direction (the same sums)
    same = seg_flat.take(at[:, 2:6]) == slab[:, None]
    steps = np.bincount((slab[:, None] + np.arange(4) * (n_s + 1))[same], minlength=4 * (n_s + 1)).reshape(4, n_s + 1)
    length = np.zeros(n_s + 1)
    for k in range(4):
        length += (np.sqrt(2) if k in (1, 3) else 1.0) * steps[k]
    sn = _unique_pairs_numpy(sn) - 1                                  # sorted by segment, then node
    nn = _unique_pairs_numpy(nn) - 1
    ends = np.full((n_s, 2), -1)
    first = np.searchsorted(sn[:, 0], sn[:, 0])               # rank of each contact within its segment
    rank = np.arange(len(sn)) - first
    two = rank < 2
    ends[sn[two, 0], rank[two]] = sn[two, 1]
    filled = np.minimum(np.bincount(sn[:, 0], minlength=n_s), 2)
    length = length[1:] + filled                    # plus one step onto each end node
    seg_nodes = np.vstack([ends, nn]).astype(int) if len(nn) else ends
    seg_yx = seg_yx + [np.zeros((0, 2), int)] * len(nn)
    length = np.concatenate([length, np.ones(len(nn))]) * skel.scale
    return SkeletonGraph(img.shape, skel.scale, node_yx, node_kind, node_pixels, seg_nodes.reshape(-1, 2),
                         seg_yx, length)


def test_graph_core_gives_the_numpy_graph():
    """build_graph (its pixel work compiled) gives the numpy and cv2.connectedComponents graph, every
    array the same, on random images (any pixels, any scale) and their thinned skeletons; the kernel's
    component labels are cv2.connectedComponents' numbers."""
    import cv2

    from appliance.localize.graph import build_graph
    from appliance.localize.skeleton import Skeleton, SparseImage, neighbour_tables, skeletonize

    rng = np.random.default_rng(9)
    for _ in range(150):
        h, w = rng.integers(1, 45, 2)
        img = (rng.random((h, w)) < rng.uniform(0.02, 0.7)).astype(np.uint8)
        for skel in (Skeleton(img, int(rng.integers(1, 5))), skeletonize(img * 255, "thinning")):
            a, b = build_graph(skel), _build_graph_numpy(skel)
            assert a.shape == b.shape and a.scale == b.scale
            for f in ("node_yx", "node_kind", "seg_nodes", "seg_length_px", "seg_recovered"):
                assert getattr(a, f).dtype == getattr(b, f).dtype
                np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
            for f in ("node_pixels", "seg_yx"):
                assert len(getattr(a, f)) == len(getattr(b, f))
                for p, q in zip(getattr(a, f), getattr(b, f)):
                    np.testing.assert_array_equal(p, q)
        sp = SparseImage.from_image(img)
        idx = np.flatnonzero(sp.flat)
        _, jlab, n_j, _, _, _, _, _ = kernels_graph.graph_core(sp.flat, idx, w + 2, w, np.full(256, 3, np.uint8))
        n, lab = cv2.connectedComponents(img, connectivity=8, ltype=cv2.CV_32S)    # (every pixel a junction)
        assert n_j == n - 1
        np.testing.assert_array_equal(jlab, lab.reshape(-1)[np.flatnonzero(img)])
    assert len(build_graph(Skeleton(np.eye(6, dtype=np.uint8))).seg_yx) == 1 and neighbour_tables()[0][3] == 2
