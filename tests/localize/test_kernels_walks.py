"""The mask walks and bilinear reads (localize/kernels_walks.py) against OpenCV and the numpy steps."""

from __future__ import annotations

import cv2
import numpy as np

from appliance.localize import kernels_walks, tips


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
        return np.array([kernels_walks.bilinear_u8(img, xy[i, 0], xy[i, 1]) for i in range(len(xy))])

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
            got = kernels_walks.child_outline_pairs(mask, bases, s_c, e, reach, r_child, sin_t)
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
            sel, dist = kernels_walks.near_points(pts, float(p[0]), float(p[1]), lo, hi)
            want = np.hypot(*(pts - p).T)
            np.testing.assert_array_equal(dist, want)
            np.testing.assert_array_equal(sel, pts[(want >= lo) & (want <= hi)])


def test_last_on_is_the_remap_of_all_lines():
    """Lines from inside and outside blurred discs, in all directions, with and without their own sample
    counts: the same crossings (NaN included) as one cv2.remap of every line, bit for bit."""
    rng = np.random.default_rng(2)
    n_lines = n_found = 0
    for trial in range(200):
        h, w = int(rng.integers(20, 80)), int(rng.integers(20, 80))
        m = np.zeros((h, w), np.uint8)
        centres = rng.integers(0, (w, h), (3, 2))
        for x, y in centres:
            cv2.circle(m, (int(x), int(y)), int(rng.integers(3, 20)), 255, -1)
        m = cv2.GaussianBlur(m, (5, 5), 1.0)
        k = int(rng.integers(1, 12))
        starts = rng.uniform(-2, max(h, w) + 2, (k, 2))
        starts[: k // 2] = centres[rng.integers(0, 3, k // 2)] + rng.normal(0, 1, (k // 2, 2))
        ang = rng.uniform(0, 2 * np.pi, k)
        dirs = np.column_stack([np.cos(ang), np.sin(ang)])
        s = np.arange(0.0, rng.uniform(1.5, 40), 0.5)
        n_s = rng.integers(1, len(s) + 1, k) if trial % 2 else None
        got = tips._last_on(m, starts, dirs, s, n_s)
        want = tips._last_on_np(m, starts, dirs, s, n_s)
        assert got.dtype == want.dtype and np.array_equal(got, want, equal_nan=True)
        n_lines += k
        n_found += int(np.isfinite(got).sum())
    assert n_found > 0.2 * n_lines                 # many lines do cross the outline


def _crossing_np(val, t, i_off, step):
    """Where the coverage crosses 128 between sample ``i_off`` (off) and ``i_off - step`` (on) per row."""
    rows = np.arange(len(val))
    i_on = np.clip(i_off - step, 0, val.shape[1] - 1)
    i_off = np.clip(i_off, 0, val.shape[1] - 1)
    v_off, v_on = val[rows, i_off].astype(np.float64), val[rows, i_on].astype(np.float64)
    f = (v_on - 128.0) / np.maximum(v_on - v_off, 1e-9)
    return t[i_on] + f * (t[i_off] - t[i_on])


def _sections_numpy(mask, base, e, n, s, t, gap_px):
    """``forkalong.sections`` before the kernel: one cv2.remap of every section's samples, then the runs
    by numpy (the reference of :func:`kernels_walks.section_runs`)."""
    mx = (base[0] + s[:, None] * e[0]) + t[None, :] * n[0]
    my = (base[1] + s[:, None] * e[1]) + t[None, :] * n[1]
    val = cv2.remap(mask, mx.astype(np.float32), my.astype(np.float32), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=0).astype(np.float32)
    on = val >= 128.0
    nt = len(t)
    j = np.arange(nt)[None, :]
    i0 = int(np.argmin(np.abs(t)))
    ok = on[:, i0]
    off = ~on
    lo_off = np.where(off & (j < i0), j, -1).max(1)
    hi_off = np.where(off & (j > i0), j, nt).min(1)
    ok &= (lo_off >= 0) & (hi_off < nt)
    lo = _crossing_np(val, t, lo_off, -1)
    hi = _crossing_np(val, t, hi_off, 1)
    c_on = np.where(on & (j > hi_off[:, None]), j, nt).min(1)
    c_off = np.where(off & (j > c_on[:, None]), j, nt).min(1)
    child = ok & (c_on < nt) & (c_off < nt)
    cl = _crossing_np(val, t, c_on - 1, -1)
    ch = _crossing_np(val, t, c_off, 1)
    child &= (cl - hi) <= gap_px
    nan = np.full(len(s), np.nan)
    return {"ok": ok, "lo": np.where(ok, lo, nan), "hi": np.where(ok, hi, nan),
            "child": child, "cl": np.where(child, cl, nan), "ch": np.where(child, ch, nan)}


def test_section_runs_is_one_remap_of_every_section():
    """The along-parent fork's sections (forkalong.sections): soft bars crossing and touching, sections in all
    directions, partly off the image, with gaps large and small: the same runs and crossings (NaN included),
    bit for bit, as one cv2.remap of every sample and numpy's scans."""
    from appliance.localize.forkalong import sections
    rng = np.random.default_rng(11)
    n_ok = n_child = n_all = 0
    for _ in range(40):
        # a parent bar, a child bar beside it at a small angle (touching it or apart), a third bar anywhere
        mask = np.zeros((120, 160), np.uint8)
        a = rng.uniform(0, 2 * np.pi)
        e = np.array([np.cos(a), np.sin(a)])
        n = np.array([-e[1], e[0]])
        c = rng.uniform(30, 130, 2)
        w_par, w_ch = rng.uniform(4, 24), rng.uniform(3, 12)
        b = np.radians(rng.uniform(-15, 15))
        e_ch = np.cos(b) * e + np.sin(b) * n
        c_ch = c + (0.5 * (w_par + w_ch) + rng.uniform(-3, 12)) * n
        for (p, d), w in (((c, e), w_par), ((c_ch, e_ch), w_ch)):
            cv2.line(mask, tuple(int(v) for v in p - 200 * d), tuple(int(v) for v in p + 200 * d), 255,
                     int(round(w)), cv2.LINE_AA)
        cv2.line(mask, tuple(int(v) for v in rng.integers(0, 160, 2)), tuple(int(v) for v in rng.integers(0, 160, 2)),
                 255, int(rng.integers(3, 25)), cv2.LINE_AA)
        mask = cv2.GaussianBlur(mask, (5, 5), rng.uniform(0.3, 1.5))
        base = c + rng.normal(0, 1.0, 2)
        r = np.radians(rng.uniform(-10, 10))
        e, n = np.cos(r) * e + np.sin(r) * n, np.cos(r) * n - np.sin(r) * e
        s = np.arange(-rng.uniform(10, 80), rng.uniform(0, 60), 1.0)
        t = np.arange(np.floor(-rng.uniform(5, 40)), rng.uniform(5, 80), 1.0) + rng.uniform(-0.5, 0.5)
        gap = rng.uniform(2, 40)
        got = sections(mask, base, e, n, s, t, gap)
        want = _sections_numpy(mask, base, e, n, s, t, gap)
        for k in want:
            assert got[k].dtype == want[k].dtype and np.array_equal(got[k], want[k], equal_nan=k not in ("ok", "child"))
        n_ok += int(want["ok"].sum())
        n_child += int(want["child"].sum())
        n_all += len(s)
    assert n_ok > 0.5 * n_all and n_child > 0.15 * n_all      # runs and further runs found, not only NaN
