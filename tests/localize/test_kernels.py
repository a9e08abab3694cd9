"""The compiled kernels (numba) against the numpy steps they replace."""

import numpy as np

from appliance.localize import kernels
from appliance.localize.curves import fit_groups


def test_segment_sums_are_numpys_reduceat_bit_for_bit():
    """The power sums of the fits: numpy's pairwise summation, all block sizes (< 8, <= 128, halved)."""
    rng = np.random.default_rng(1)
    for n in list(range(1, 40)) + [127, 128, 129, 130, 255, 256, 257, 600, 1031]:
        a = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 5, n)
        want = np.add.reduceat(np.concatenate([a, [0.0]]), [0, n])[0]
        assert kernels._segment_sum(a, 0, n) == want
        assert kernels._median(a) == np.median(a)
        ties = np.round(a[: n // 2 + 1] / 1e3)                     # (repeated values)
        assert kernels._median(ties) == np.median(ties)


def test_fit_groups_is_least_squares_per_group():
    """Each group's polynomial is the least-squares one (np.polyfit in the scaled parameter), its
    degree lowered to what its distinct parameters support; an empty group gets a constant 0."""
    rng = np.random.default_rng(2)
    ts = [np.sort(rng.choice(np.arange(500.0), 60, replace=False)), np.zeros(0), np.repeat([3.0, 9.0], 5),
          np.sort(rng.uniform(0, 80, 30))]
    degrees = np.array([3, 2, 3, 2])
    ys = [0.002 * t ** 2 - 0.3 * t + rng.normal(0, 0.5, len(t)) for t in ts]
    g = np.repeat(np.arange(len(ts)), [len(t) for t in ts])
    fit = fit_groups(np.concatenate(ts), np.concatenate(ys), g, len(ts), degrees)
    np.testing.assert_array_equal(fit.degree, [3, 0, 1, 2])
    assert not fit.coef[1].any()
    for k in (0, 2, 3):
        t, y, d = ts[k], ys[k], int(fit.degree[k])
        assert fit.t0[k] == np.add.reduceat(t, [0])[0] / len(t)
        want = np.polyfit((t - fit.t0[k]) / fit.ts[k], y, d)
        np.testing.assert_allclose(fit.coef[k, 3 - d:], want, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(fit(np.full(len(t), k), t), np.polyval(want, (t - fit.t0[k]) / fit.ts[k]),
                                   rtol=1e-12, atol=1e-9)


def test_runs_find_and_between_are_the_numpy_lookups():
    """Runs.find / Runs.between (compiled) against the numpy formulas they replace, on a soft mask
    with queries off the image and non-finite columns."""
    import cv2
    from appliance.localize.edges import find_runs

    rng = np.random.default_rng(0)
    for _ in range(20):
        h, w = 60, int(rng.integers(20, 300))
        m = (cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 3) > 0.5).astype(np.uint8) * 255
        runs = find_runs(cv2.GaussianBlur(m, (3, 3), 0), soft=True)
        row = rng.integers(-2, h + 2, 300)
        x = rng.uniform(-3, w + 3, 300)
        x[::37] = np.nan
        xi = np.rint(np.nan_to_num(x, nan=-1e9)).astype(int)
        key, start = row * w + xi, runs.row * w + runs.x0
        i = np.searchsorted(start, key, side="right") - 1
        ok = np.isfinite(x) & (i >= 0) & (runs.row[np.maximum(i, 0)] == row) & (runs.x1[np.maximum(i, 0)] >= xi)
        np.testing.assert_array_equal(runs.find(row, x), np.where(ok, i, -1))
        lo = rng.uniform(-10, w, 300)
        hi = lo + rng.uniform(-5, 60, 300)
        q, r = runs.between(row, lo, hi)
        centre = runs.row * w + runs.centre_px
        want = [(k, j) for k in range(len(row)) for j in np.flatnonzero((centre >= row[k] * w + lo[k])
                                                                         & (centre <= row[k] * w + hi[k]))]
        assert list(zip(q.tolist(), r.tolist())) == want


def test_bilinear_reads_are_cv2_remaps():
    """The walks' mask reads: cv2.remap's bilinear value of uint8 images (border 0), points on and
    off the image, 2e5 of them. OpenCV 5 interpolates in float32 by fused multiply-adds, as the kernel:
    the same values (on a CPU without FMA, or OpenCV 4's fixed-point tables, a few points are one
    level off); the walks then follow those values."""
    import cv2
    import numba
    from appliance.localize.walks import walk_edges

    @numba.njit
    def read(img, xy):
        return np.array([kernels.bilinear_u8(img, xy[i, 0], xy[i, 1]) for i in range(len(xy))])

    rng = np.random.default_rng(7)
    img = rng.integers(0, 256, (60, 80), dtype=np.uint8)
    xy = np.column_stack([rng.uniform(-3, 83, 200_000), rng.uniform(-3, 63, 200_000)]).astype(np.float32)
    want = cv2.remap(img, xy.reshape(-1, 1000, 2), None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                     borderValue=0).reshape(-1)
    got = read(img, xy)
    assert np.abs(got - want).max() <= 1
    assert np.count_nonzero(got != want) <= (2 if int(cv2.__version__.split(".")[0]) >= 5 else len(xy) // 2)
    # one walk per 1000 points: each walk's first point off the mask (< 127.5) and the crossing before it
    bounds = np.arange(0, len(xy) + 1, 1000)
    idx, crosses = walk_edges(img, xy.astype(float), bounds)
    v = got.reshape(-1, 1000).astype(np.float32)
    on = v >= 127.5
    first_off = np.where(on.all(1), 1000, np.argmin(on, 1))
    np.testing.assert_array_equal(crosses, (first_off > 0) & (first_off < 1000))
    k = np.maximum(first_off, 1)
    a, b = (v[np.arange(len(k)), np.minimum(j, 999)] for j in (k - 1, k))
    frac = np.clip((a - 127.5) / np.maximum(a - b, 1e-6), 0.0, 1.0)
    np.testing.assert_array_equal(idx, np.where(crosses, (k - 1) + frac, np.maximum(first_off - 1, 0)))


def test_warm_up_compiles_every_signature_the_localizer_uses():
    """After a Localizer is built (it warms the kernels up), localizing compiles nothing more: no frame
    waits for numba (a live stream's first result, a worker's first pair)."""
    from pathlib import Path

    import cv2
    import numba
    from appliance.calibrate.model import load_calibration
    from appliance.config import load_config
    from appliance.localize import Localizer

    fixtures = Path(__file__).resolve().parents[2] / "fixtures"
    loc = Localizer(load_calibration(fixtures / "rig.yaml"), load_config().localize)
    jitted = {n: f for n, f in vars(kernels).items()      # (the ones the localizer calls)
              if isinstance(f, numba.core.registry.CPUDispatcher) and not n.startswith("_") and n != "bilinear_u8"}
    before = {n: len(f.signatures) for n, f in jitted.items()}
    loc.localize(cv2.imread(str(fixtures / "scenes" / "left_00.png")), cv2.imread(str(fixtures / "scenes" / "right_00.png")))
    assert {n: len(f.signatures) for n, f in jitted.items()} == before
    assert all(before.values())


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


def _unmix_numpy(bgr, mask, window_px, band_px, factor=4):
    """The numpy steps unmix_blocks replaced (segment.unmix_edges before the kernel)."""
    import cv2

    from appliance.localize.segment import _K3, _MIN_SIN2, sample_nearest
    from appliance.localize.skeleton import block_mean
    h, w = mask.shape
    hs, ws = h // factor, w // factor
    ring = cv2.morphologyEx(mask, cv2.MORPH_GRADIENT, np.ones((2 * band_px + 1,) * 2, np.uint8))
    bi = np.flatnonzero(block_mean(ring[:hs * factor, :ws * factor], factor) != 0)
    out = mask.copy()
    small = sample_nearest(bgr, factor)
    ms = cv2.resize(mask[:hs * factor, :ws * factor], (ws, hs), interpolation=cv2.INTER_NEAREST)
    chi = np.array(cv2.mean(small, mask=cv2.erode(ms, _K3))[:3], np.float32)
    if not chi.any():
        chi = np.array(cv2.mean(small, mask=ms)[:3], np.float32)
    chi /= max(float(np.linalg.norm(chi)), 1e-6)
    away = cv2.bitwise_not(cv2.dilate(ms, _K3))
    win = (max(1, round(window_px / factor)),) * 2
    n_o = cv2.boxFilter(away, cv2.CV_32F, win, normalize=False)
    s_o = cv2.boxFilter(cv2.bitwise_and(small, small, mask=away), cv2.CV_32F, win, normalize=False)
    n = n_o.reshape(-1).take(bi) * (1.0 / 255)
    c_o = s_o.reshape(-1, 3).take(bi, axis=0) / np.maximum(n, 1.0)[:, None]
    c_chi = c_o @ chi
    c_c = np.einsum("ij,ij->i", c_o, c_o)
    det = c_c - c_chi * c_chi
    ok = (n > 0.5) & (det > _MIN_SIN2 * c_c)
    bi, v = bi[ok], (c_o[ok] - c_chi[ok, None] * chi) / det[ok, None]
    off = (np.arange(factor)[:, None] * w + np.arange(factor)).reshape(-1)
    fi = ((bi // ws) * (factor * w) + (bi % ws) * factor)[:, None] + off
    on = np.flatnonzero(ring.reshape(-1).take(fi) != 0)
    fi = fi.reshape(-1).take(on)
    v = v.take(on // (factor * factor), axis=0)
    p = bgr.reshape(-1, 3).take(fi, axis=0).astype(np.float32)
    cover = p[:, 0] * v[:, 0]
    cover += p[:, 1] * v[:, 1]
    cover += p[:, 2] * v[:, 2]
    cover = 1.0 - cover
    out.reshape(-1)[fi] = np.minimum(np.maximum(cover * 255.0 + 0.5, 0), 255).astype(np.uint8)
    return out


def test_unmix_blocks_gives_the_numpy_steps_coverage():
    """unmix_edges (its blocks and outline pixels compiled) equals the numpy steps it replaced, bit for
    bit, on a fixture scene's cleaned mask and on a noisy rendered disc (both outline bands)."""
    from pathlib import Path

    import cv2

    from appliance.config import load_config
    from appliance.localize.segment import bark_hsv, clean_mask, unmix_edges

    cfg = load_config().localize.segment
    img = cv2.imread(str(Path(__file__).resolve().parents[2] / "fixtures" / "scenes" / "left_00.png"))
    mask = clean_mask(bark_hsv(img, cfg)[1], cfg)
    rng = np.random.default_rng(7)
    disc = np.zeros((122, 161), np.uint8)
    cv2.circle(disc, (80, 60), 33, 255, -1)
    noisy = np.clip(np.where(disc[..., None] > 0, (60, 70, 90), (200, 160, 90)) + rng.normal(0, 12, (122, 161, 3)),
                    0, 255).astype(np.uint8)
    for bgr, m in ((img, mask), (cv2.GaussianBlur(noisy, (0, 0), 1.0), disc)):
        for band in (1, 2):
            want = _unmix_numpy(bgr, m, 20, band)
            assert np.count_nonzero((want > 0) & (want < 255)) > 100
            np.testing.assert_array_equal(unmix_edges(bgr, m, 20, band), want)


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
    """graph.build_graph before kernels.graph_core (numpy and cv2.connectedComponents)."""
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
        _, jlab, n_j, _, _, _, _, _ = kernels.graph_core(sp.flat, idx, w + 2, w, np.full(256, 3, np.uint8))
        n, lab = cv2.connectedComponents(img, connectivity=8, ltype=cv2.CV_32S)    # (every pixel a junction)
        assert n_j == n - 1
        np.testing.assert_array_equal(jlab, lab.reshape(-1)[np.flatnonzero(img)])
    assert len(build_graph(Skeleton(np.eye(6, dtype=np.uint8))).seg_yx) == 1 and neighbour_tables()[0][3] == 2


def _child_outline_pairs_numpy(mask, bases, s_c, e, r_child, sin_t):
    """The Python steps the kernel replaced: ``_line_samples`` of the four lines, then
    ``_interval_middle`` pair by pair."""
    from appliance.localize.ends import EndPlacer
    samples = EndPlacer._line_samples(list(zip(bases, s_c.tolist())), e, r_child, sin_t, mask)
    for i in range(2):
        m1 = EndPlacer._interval_middle(*samples[2 * i], r_child, sin_t)
        if m1 is None:
            continue
        m2 = EndPlacer._interval_middle(*samples[2 * i + 1], r_child, sin_t)
        if m2 is not None:
            return i, m1, m2
    return -1, 0.0, 0.0


def test_child_outline_pairs_is_line_samples_and_interval_middles():
    """The child's intervals on the fork's four lines: the same pair and the same middles, bit for
    bit, as sampling the lines by ``cv2.remap`` and scanning them in Python (random soft discs and
    bars, random lines across them, clear and unclear)."""
    import cv2
    rng = np.random.default_rng(5)
    found = 0
    for _ in range(60):
        mask = np.zeros((160, 200), np.uint8)
        for _ in range(3):
            p0 = tuple(int(v) for v in rng.integers(0, 200, 2))
            p1 = tuple(int(v) for v in rng.integers(0, 200, 2))
            cv2.line(mask, p0, p1, 255, int(rng.integers(3, 25)), cv2.LINE_AA)
        mask = cv2.GaussianBlur(mask, (5, 5), rng.uniform(0.3, 1.5))
        for _ in range(20):
            a = rng.uniform(0, np.pi)
            e = np.array([np.cos(a), np.sin(a)])
            n = np.array([-e[1], e[0]])
            c1 = rng.uniform(20, 180, 2)
            hs = np.sort(rng.uniform(-30, 30, 4))
            bases = c1 + hs[:, None] * n
            s_c = rng.uniform(-60, 60) + hs * rng.normal(0, 0.5)
            r_child, sin_t = rng.uniform(1.5, 12.0), rng.uniform(0.2, 1.0)
            reach = (4.7 * r_child + 3) / sin_t + 2
            got = kernels.child_outline_pairs(mask, bases, s_c, e, reach, r_child, sin_t)
            want = _child_outline_pairs_numpy(mask, bases, s_c, e, r_child, sin_t)
            assert (int(got[0]), float(got[1]), float(got[2])) == want
            found += want[0] >= 0
    assert found > 50


def test_near_points_is_numpys_hypot_selection():
    """A junction's near points: the same distances (np.hypot) and the same points, in order."""
    rng = np.random.default_rng(6)
    for n in (0, 1, 3, 40, 500):
        pts = rng.uniform(-50, 300, (n, 2)) * rng.choice([1.0, 1e-3, 1e3])
        pts.setflags(write=False)
        p = rng.uniform(0, 200, 2)
        for lo, hi in ((0.0, 1e9), (10.0, 60.0), (30.0, 30.0)):
            sel, dist = kernels.near_points(pts, float(p[0]), float(p[1]), lo, hi)
            want = np.hypot(*(pts - p).T)
            np.testing.assert_array_equal(dist, want)
            np.testing.assert_array_equal(sel, pts[(want >= lo) & (want <= hi)])
