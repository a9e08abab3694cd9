"""kernels_stubs (localize/kernels_stubs.py) against plain numpy / OpenCV references: the block components free
of taken points and their dense cells (stub_seeds), and the full mask's components read from them
(stub_pixels) against the whole mask's labelling that stubtips.py did before (random drawn masks)."""

import cv2
import numpy as np
from appliance.localize import kernels_stubs
from appliance.localize.skeleton import skeletonize
from appliance.localize.stubtips import MIN_RADIUS_PX, min_cell_px

H, W, S = 240, 320, 4


def _mask(rng: np.random.Generator) -> np.ndarray:
    """Random soft branches, stubs, blobs and specks (uint8 0-255), some touching the border or each other."""
    m = np.zeros((H, W), np.uint8)
    for _ in range(rng.integers(6, 16)):
        kind = rng.integers(0, 4)
        x, y = rng.uniform(-10, W + 10), rng.uniform(-10, H + 10)
        if kind == 0:                                       # a stub or a branch
            a, n = rng.uniform(0, np.pi), rng.uniform(8, 120)
            x2, y2 = x + n * np.cos(a), y + n * np.sin(a)
            cv2.line(m, (int(x * 16), int(y * 16)), (int(x2 * 16), int(y2 * 16)), 255,
                     int(rng.integers(1, 16)), cv2.LINE_AA, 4)
        elif kind == 1:                                     # a blob
            cv2.circle(m, (int(x * 16), int(y * 16)), int(rng.uniform(1, 9) * 16), 255, -1, cv2.LINE_AA, 4)
        elif kind == 2:                                     # specks
            for _ in range(20):
                m[int(rng.integers(0, H)), int(rng.integers(0, W))] = 255
        else:                                               # a thin curve with a tail
            pts = np.cumsum(rng.normal(0, 6, (8, 2)), axis=0) + (x, y)
            cv2.polylines(m, [np.int32(pts * 16)], False, 255, int(rng.integers(1, 4)), cv2.LINE_AA, 4)
    return m


def _reference(mask: np.ndarray, taken: np.ndarray, min_area: int, max_area: int) -> list:
    """The stub rule's candidates as stubtips.py found them before: the whole mask's 8-connected components of
    min_area ... max_area px holding no taken point and not touching the border, (rows, cols) in raster order,
    in the order of their labels; with the radius test of stub_tips applied."""
    h, w = mask.shape
    n, lab = cv2.connectedComponents((mask >= 128).view(np.uint8), connectivity=8)
    area = np.bincount(lab.ravel(), minlength=n)
    cand = (area >= min_area) & (area <= max_area)
    cand[0] = False
    q = np.rint(taken).astype(int)
    ok = (q[:, 0] >= 0) & (q[:, 0] < w) & (q[:, 1] >= 0) & (q[:, 1] < h)
    cand[lab[q[ok, 1], q[ok, 0]]] = False
    out = []
    for k in np.flatnonzero(cand):
        ys, xs = np.nonzero(lab == k)
        if ys.min() == 0 or xs.min() == 0 or ys.max() == h - 1 or xs.max() == w - 1:
            continue
        out.append((ys, xs))
    return out


def _radius(ys: np.ndarray, xs: np.ndarray) -> float:
    """stub_tips' half width of a component: the largest distance-transform value less half a pixel."""
    crop = np.zeros((ys.max() - ys.min() + 3, xs.max() - xs.min() + 3), np.uint8)
    crop[ys - ys.min() + 1, xs - xs.min() + 1] = 1
    return float(cv2.distanceTransform(crop, cv2.DIST_L2, 5).max()) - 0.5


def _kernel(mask: np.ndarray, taken: np.ndarray, min_area: int, max_area: int) -> list:
    block = skeletonize(mask, "fast", S, level=127).mask
    n, labels = cv2.connectedComponents(block, connectivity=8)
    pixels, starts = kernels_stubs.stub_pixels(labels, n, mask, S, taken, min_cell_px(S), min_area, max_area)
    return [(pixels[a:b, 0], pixels[a:b, 1]) for a, b in zip(starts[:-1], starts[1:])]


def test_min_cell_px_is_what_a_stubs_widest_disc_covers_of_one_cell():
    """Every component whose half width passes the stub test (>= MIN_RADIUS_PX) holds at least min_cell_px(4)
    (13) pixels of one 4 x 4 cell: checked on discs and bars of every sub-pixel place near the bound."""
    rng = np.random.default_rng(7)
    assert min_cell_px(4) == 13 and min_cell_px(1) == 1 and 2 * min_cell_px(2) > 4
    tried = 0
    for _ in range(400):
        m = np.zeros((40, 40), np.uint8)
        c = rng.uniform(14, 26, 2)
        r = rng.uniform(3.3, 4.2)
        if rng.random() < 0.5:
            cv2.circle(m, tuple(np.int32(c * 16)), int(r * 16), 255, -1, cv2.LINE_AA, 4)
        else:
            a = rng.uniform(0, np.pi)
            e = np.array([np.cos(a), np.sin(a)]) * 8
            cv2.line(m, tuple(np.int32((c - e) * 16)), tuple(np.int32((c + e) * 16)), 255, int(2 * r), cv2.LINE_AA, 4)
        ys, xs = np.nonzero(m >= 128)
        if _radius(ys, xs) < MIN_RADIUS_PX:
            continue
        tried += 1
        cells = np.bincount((ys // 4) * 10 + xs // 4, minlength=100)
        assert cells.max() >= min_cell_px(4)
    assert tried > 100


def test_stub_pixels_finds_the_whole_mask_labellings_candidates():
    """On random masks, with random taken points: every component the whole mask's labelling lists (area,
    border, taken) that passes the radius test is found, with the same pixels in the same order; every
    component found is one it lists (the kernel finds no other). (A stub joined to a taken component in the
    block mask is the kernel's one omission: the masks here are checked for it and such cases skipped.)"""
    rng = np.random.default_rng(22)
    found = 0
    for trial in range(60):
        mask = _mask(rng)
        ys, xs = np.nonzero(mask >= 128)
        pick = rng.choice(len(ys), size=min(len(ys), int(rng.integers(0, 12))), replace=False)
        taken = np.column_stack([xs[pick], ys[pick]]).astype(float) + rng.uniform(-0.49, 0.49, (len(pick), 2))
        ref = _reference(mask, taken, 60, 900)
        got = _kernel(mask, taken, 60, 900)
        keys_ref = {(int(a[0]), int(b[0])): (a, b) for a, b in ref}
        for a, b in got:                                    # nothing but listed candidates
            assert (int(a[0]), int(b[0])) in keys_ref
            ra, rb = keys_ref[(int(a[0]), int(b[0]))]
            assert np.array_equal(a, ra) and np.array_equal(b, rb)
        keys_got = {(int(a[0]), int(b[0])) for a, b in got}
        block = skeletonize(mask, "fast", S, level=127).mask
        n, labels = cv2.connectedComponents(block, connectivity=8)
        q = np.rint(taken).astype(int)
        on = mask[q[:, 1], q[:, 0]] >= 128
        taken_blocks = set(labels[q[on, 1] // S, q[on, 0] // S].tolist()) - {0}
        for a, b in ref:
            if _radius(a, b) < MIN_RADIUS_PX:
                continue
            if taken_blocks & set(labels[a // S, b // S].tolist()):
                continue                                    # joined to a taken one in the block mask
            assert (int(a[0]), int(b[0])) in keys_got
            found += 1
    assert found >= 20


def test_stub_seeds_lists_free_components_and_dense_cells():
    """stub_seeds against numpy: the block components holding no taken branch pixel, their boxes, and their
    cells with >= min_cell_px branch pixels (counted by a reshape of the mask)."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        mask = _mask(rng)
        block = skeletonize(mask, "fast", S, level=127).mask
        n, labels = cv2.connectedComponents(block, connectivity=8)
        ys, xs = np.nonzero(mask >= 128)
        pick = rng.choice(len(ys), size=min(len(ys), 5), replace=False)
        taken = np.column_stack([xs[pick], ys[pick]]).astype(float)
        taken = np.vstack([taken, [[-5.0, 3.0], [1e9, 2.0], [np.nan, 1.0], [3.0, 3.0]]])    # off the image / mask
        boxes, cells = kernels_stubs.stub_seeds(labels, n, mask, S, taken, 13)
        count = (mask >= 128).reshape(H // S, S, W // S, S).sum(axis=(1, 3))
        hit = set(labels[ys[pick] // S, xs[pick] // S].tolist())
        if mask[3, 3] >= 128 and labels[0, 0]:
            hit.add(int(labels[0, 0]))
        want = []
        for k in range(1, n):
            if k in hit:
                continue
            cy, cx = np.nonzero(labels == k)
            dense = (count[cy, cx] >= 13)
            if dense.any():
                want.append(((cy.min(), cx.min(), cy.max(), cx.max()), sorted(zip(cy[dense], cx[dense]))))
        assert len(boxes) == len(want)
        for i, (box, cl) in enumerate(want):
            assert tuple(boxes[i]) == box
            assert sorted(map(tuple, cells[cells[:, 0] == i][:, 1:].tolist())) == [tuple(map(int, c)) for c in cl]


def _walk_end_numpy(mask, start, out, reach, step=0.25):
    """stubtips._walk_end's numpy steps before the kernel (stop 21)."""
    h, w = mask.shape
    t = np.arange(0.0, reach, step)
    pts = start[None, :] + t[:, None] * out[None, :]
    ij = np.rint(pts).astype(int)
    inside = (ij[:, 0] >= 0) & (ij[:, 0] < w) & (ij[:, 1] >= 0) & (ij[:, 1] < h)
    on = np.zeros(len(t), bool)
    on[inside] = mask[ij[inside, 1], ij[inside, 0]] >= 128
    if not on[0]:
        return None
    off = np.flatnonzero(~on)
    if len(off) == 0 or not inside[off[0]]:
        return None
    return start + (t[off[0] - 1] + 0.5 * step) * out


def test_walk_end_gives_the_numpy_walks_points_bit_for_bit():
    """walk_end against the numpy steps it replaced, on random discs, starts (some off the image or the disc),
    directions and reaches: the same outcome, and the same end point to the last bit where there is one."""
    rng = np.random.default_rng(3)
    ends = 0
    for _ in range(3000):
        m = np.zeros((60, 80), np.uint8)
        cv2.circle(m, (int(rng.integers(0, 80)), int(rng.integers(0, 60))), int(rng.integers(3, 30)), 255, -1)
        start = rng.uniform(-2, 82, 2) * [1, 0.75]
        a = rng.uniform(0, 2 * np.pi)
        out = np.array([np.cos(a), np.sin(a)])
        reach = float(rng.uniform(0.1, 90))
        want = _walk_end_numpy(m, start, out, reach)
        ok, x, y = kernels_stubs.walk_end(m, float(start[0]), float(start[1]), float(out[0]), float(out[1]),
                                          reach, 0.25)
        assert ok == (want is not None)
        if ok:
            assert x == want[0] and y == want[1]
            ends += 1
    assert ends > 100
