"""The tips' kernels (localize/kernels_tips.py, the seventh numba pass) against the numpy code they
replaced (kept here as the reference: the functions of tips.py and ends.py before the pass)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import cv2
import numpy as np
from appliance.localize import caps, kernels_ncc, kernels_tips, tips
from appliance.localize.curves import median
from appliance.localize.edges import find_runs
from appliance.localize.ends import EndPlacer
from appliance.localize.tipends import (CAP_SPLIT_PX, CAP_SPLIT_SHARE, END_ROWS_OUTVOTE, END_RUN_CUT_PX,
                                       OWN_CAP_PX, OWN_CAP_ROWS, OWN_EDGE_PX, OWN_EDGE_ROWS, OWN_EDGE_SHARE,
                                       OWN_EDGE_WIDTH, cap_row_scale)
from appliance.localize.tips import (CAP_EDGE_BACK, CAP_WIDTH_BACK, _last_on_np, at_view_edge, silhouette_offset_px,
                                     split_row_disparity)

F_PX = 1450.0


def _ref_cap_shapes_offsets(mask, ends_):
    """tips.cap_shapes_offsets before the pass (two cv2.remap reads of all lines)."""
    ns = [np.array([-out[1], out[0]]) for _, out, _ in ends_]
    ps = [uv_edge - CAP_WIDTH_BACK * r * out for uv_edge, out, r in ends_]
    s1 = [np.arange(0.0, 3.0 * r + 4.0, 0.5) for _, _, r in ends_]
    w = _last_on_np(mask, np.stack([q for p in ps for q in (p, p)]), np.stack([m for n in ns for m in (n, -n)]),
                    max(s1, key=len), np.repeat([len(s) for s in s1], 2)).reshape(-1, 2)
    offsets = 0.5 * (w[:, 0] - w[:, 1])
    out_shapes, readable, starts, dirs, s2, variants_all = [None] * len(ends_), [], [], [], [], []
    for i, ((_, out, r), n, p, (wa, wb)) in enumerate(zip(ends_, ns, ps, w)):
        if not (np.isfinite(wa) and np.isfinite(wb)):
            continue
        variants = ((0.5 * (wa + wb), p + 0.5 * (wa - wb) * n), (min(wa, wb), p))
        starts.append(np.stack([q for rho, mid in variants for q in (mid, mid + 0.7 * rho * n, mid - 0.7 * rho * n)]))
        dirs.append(np.broadcast_to(out, (6, 2)))
        s2.append(np.arange(0.0, 1.5 * r + 2.0 * variants[0][0] + 4.0, 0.5))
        variants_all.append(variants)
        readable.append(i)
    if not readable:
        return out_shapes, offsets
    e = _last_on_np(mask, np.concatenate(starts), np.concatenate(dirs), max(s2, key=len),
                    np.repeat([len(s) for s in s2], 6)).reshape(-1, 2, 3)
    for i, variants, ei in zip(readable, variants_all, e):
        shapes = []
        for (rho, _), ev in zip(variants, ei):
            if not np.isfinite(ev[0]):
                shapes.append(None)
                continue
            ev = np.where(np.isfinite(ev), ev, np.inf)
            expect = (1.0 - np.sqrt(0.51)) * rho
            shapes.append((float(rho), float((ev[0] - ev[1]) / expect), float((ev[0] - ev[2]) / expect)))
        out_shapes[i] = shapes
    return out_shapes, offsets


def _ref_cap_disparity(sm, centre_xy, half_px, out, min_margin=caps.MIN_FIT_MARGIN):
    """caps.cap_disparity before the pass (numpy steps around kernels_ncc.masked_sqdiff)."""
    h, w = sm.left_mask.shape
    x, y = np.rint(centre_xy).astype(int)
    x0, x1, y0, y1 = x - half_px, x + half_px + 1, y - half_px, y + half_px + 1
    if x0 < 0 or y0 < 0 or x1 > w or y1 > h:
        return None
    patch = sm.left_mask[y0:y1, x0:x1].astype(np.float32)
    yy, xx = np.arange(y0, y1)[:, None], np.arange(x0, x1)[None, :]
    half = ((xx - centre_xy[0]) * out[0] + (yy - centre_xy[1]) * out[1] >= -half_px / 3).astype(np.float32)
    n = float(half.sum()) * 255.0 ** 2
    dmin, dmax = sm.d_range_px
    s0, s1 = max(int(np.floor(x0 - dmax)), 0), min(int(np.ceil(x1 - dmin)), w)
    if s1 - s0 < x1 - x0 + 2:
        return None
    strip = sm.right_mask[y0:y1, s0:s1].astype(np.float32)
    err = kernels_ncc.masked_sqdiff(np.ascontiguousarray(sm.right_mask[y0:y1, s0:s1]),
                                np.ascontiguousarray(sm.left_mask[y0:y1, x0:x1]), half.astype(np.uint8)) / n
    k = int(np.argmin(err))
    cand = np.flatnonzero(np.abs(np.arange(len(err)) - k) > half_px)
    cand = cand[np.argsort(err[cand], kind="stable")[:caps.FAR_CANDIDATES]] if len(cand) else cand
    area = caps._area_err(strip, patch, half, np.r_[k, cand])
    best = float(area[0])
    if best > caps.MAX_FIT_ERROR:
        return None
    rivals = cand[area[1:] < best + min_margin] if len(cand) else cand
    if len(rivals):
        k = caps._grey_choice(sm, (y0, y1, x0, x1), s0, np.r_[k, rivals], half_px)
        if k is None:
            return None
    if sm.valid_right is not None and not sm.valid_right[y0:y1, s0 + k:s0 + k + x1 - x0][half > 0].all():
        return None
    off = 0.0
    if 0 < k < len(err) - 1:
        a, b, c = (float(v) for v in err[k - 1:k + 2])
        den = a - 2 * b + c
        off = 0.5 * (a - c) / den if den > 0 else 0.0
    return float(x0 - (s0 + k + off))


def _ref_cap_disparity_rows(rows, s, runs_l, runs_r, valid_l, valid_r, p, out, r, d_prior, h, w,
                            edge_rows=OWN_EDGE_ROWS):
    """ends.EndPlacer._cap_disparity before the pass, from its candidate rows on (``edge_rows``:
    tipends.OWN_EDGE_ROWS, 0: the rule off)."""
    il = runs_l.find(rows, s)
    rows, il = rows[il >= 0], il[il >= 0]
    if len(rows) < 3 or not len(runs_r.row):
        return None
    lo_l, hi_l = runs_l.left_px[il], runs_l.right_px[il]
    rr = runs_r.find(rows, runs_l.centre_px[il] - d_prior)
    q = np.nonzero(rr >= 0)[0]
    rr = rr[q]
    if len(q) < 3:
        return None
    rows, lo_l, hi_l = rows[q], lo_l[q], hi_l[q]
    lo_r, hi_r = runs_r.left_px[rr], runs_r.right_px[rr]
    n = len(rows)
    dv = rows - p[1]
    rows2, side2 = np.concatenate([rows, rows]), np.repeat([-1.0, 1.0], n)
    e_left, e_right = np.concatenate([lo_l, hi_l]), np.concatenate([lo_r, hi_r])
    cap = ((e_left - p[0]) * out[0] + np.concatenate([dv, dv]) * out[1] >= -CAP_EDGE_BACK * r) \
        & ~at_view_edge(rows2, e_left, side2, valid_l, w) & ~at_view_edge(rows2, e_right, side2, valid_r, w)
    cap_lo, cap_hi = cap[:n], cap[n:]
    half = np.sqrt(np.maximum(r * r - dv * dv, 0.0))
    de = e_left - e_right
    de = np.where(cap, de - silhouette_offset_px(np.full(2 * n, p[0]), de, np.concatenate([half, half]), side2,
                                                 F_PX, 0.5 * (w - 1)), np.inf)
    d_lo, d_hi = lo_l - lo_r, hi_l - hi_r
    e_lo, e_hi = de[:n], de[n:]
    both = cap_lo & cap_hi
    d = np.where(cap_lo, e_lo, e_hi)
    d[both] = split_row_disparity(0.5 * (d_lo + d_hi)[both], e_lo[both], e_hi[both], d_prior)
    if both.sum() >= 3:
        split = np.abs(e_lo[both] - e_hi[both])
        m = median(split)
        if CAP_SPLIT_PX[0] < m <= CAP_SPLIT_PX[1] and (np.abs(split - m) <= 1.0).mean() >= CAP_SPLIT_SHARE:
            return np.nan
    scale = cap_row_scale(rows, p[1], 0.5 * (h - 1), F_PX)
    d = d * scale
    own = (0.5 * (d_lo + d_hi) * scale)[both]               # (the rows' middles: none split below)
    off = lambda e: np.abs(dv * out[0] - (e - p[0]) * out[1])           # (a left edge's distance from the centre line)
    edge = d[(cap_lo | cap_hi) & (off(lo_l) <= OWN_EDGE_WIDTH * r + 1.0) & (off(hi_l) <= OWN_EDGE_WIDTH * r + 1.0)]
    d = d[(cap_lo | cap_hi) & (np.abs(d - d_prior) <= 2.5)]
    if len(d) < 3:
        if len(own) >= OWN_CAP_ROWS and not (np.abs(e_lo[both] - e_hi[both]) > tips.SPLIT_ROW_PX).any():
            m = median(own)
            if (np.abs(own - m) <= OWN_CAP_PX).all():
                return float(m)
        if edge_rows <= 0 or len(edge) < edge_rows:
            return None
        near = edge[np.abs(edge - median(edge)) <= OWN_EDGE_PX]
        if len(near) < edge_rows or len(near) < OWN_EDGE_SHARE * len(edge):
            return None
        return float(median(near))
    return float(median(d))


def _ref_end_outline_agrees(b, uv_edge, out, d, r):
    """ends.EndPlacer._end_outline_agrees before the pass."""
    k = max(1, int(0.6 * r))
    rows = int(np.rint(uv_edge[1])) + np.arange(-k, k + 1)
    rows = rows[(rows >= 0) & (rows < b.sm.left_mask.shape[0])]
    sgn = 1.0 if out[0] > 0 else -1.0
    il = b.runs_l.find(rows, np.full(len(rows), uv_edge[0] - sgn * r))
    rows, il = rows[il >= 0], il[il >= 0]
    e_l = b.runs_l.right_px[il] if sgn > 0 else b.runs_l.left_px[il]
    ir = b.runs_r.find(rows, e_l - d - sgn * r)
    if (ir >= 0).sum() < 3:
        return False
    e_r = b.runs_r.right_px[ir[ir >= 0]] if sgn > 0 else b.runs_r.left_px[ir[ir >= 0]]
    return bool((np.abs(e_l[ir >= 0] - e_r - d) <= 1.2).mean() >= 0.8)


def _ref_end_disparity(b, uv_edge, out, d_prior, r=0.0, inside_px=1.0, outvote=END_ROWS_OUTVOTE):
    """ends.EndPlacer._end_disparity before the pass (``outvote``: tipends.END_ROWS_OUTVOTE)."""
    sm = b.sm
    row = int(np.rint(uv_edge[1]))
    if not 0 <= row < sm.left_mask.shape[0]:
        return None
    runs_l, runs_r = b.runs_l, b.runs_r
    i = runs_l.find(np.array([row]), np.array([uv_edge[0] - np.sign(out[0]) * inside_px]))[0]
    if i < 0:
        return None
    j = np.arange(*np.searchsorted(runs_r.row, [row, row + 1]))
    if len(j) == 0:
        return None
    right_end = out[0] > 0
    e_l = runs_l.right_px[i] if right_end else runs_l.left_px[i]
    e_r = runs_r.right_px[j] if right_end else runs_r.left_px[j]
    d = e_l - e_r
    w = sm.left_mask.shape[1]
    sgn = 1.0 if right_end else -1.0
    ok = (d >= sm.d_range_px[0]) & (d <= sm.d_range_px[1]) \
        & ~at_view_edge(np.full(len(j), row), e_r, sgn, sm.valid_right, w)
    similar = ok & (np.abs(runs_r.span_px[j] - runs_l.span_px[i]) <= 0.2 * runs_l.span_px[i] + 3)
    if similar.any():
        d = d[similar]
        d = float(d[np.argmin(np.abs(d - d_prior))])
    else:
        d = d[ok & (np.abs(d - d_prior) <= END_RUN_CUT_PX)]
        if r <= 0 or not len(d):
            return None
        d = float(d[np.argmin(np.abs(d - d_prior))])
        if not _ref_end_outline_agrees(b, uv_edge, out, d, r):
            return None
    k = int(0.5 * r)
    cx = 0.5 * (w - 1)
    if k < 1:
        return d - silhouette_offset_px(uv_edge[0], d, r, sgn, sm.f_px, cx)
    rows = int(np.rint(uv_edge[1] - out[1] * r)) + np.arange(-k, k + 1)
    rows = rows[(rows >= 0) & (rows < sm.left_mask.shape[0])]
    il = runs_l.find(rows, np.full(len(rows), e_l - sgn * (1.0 + r)))
    rows, il = rows[il >= 0], il[il >= 0]
    el = runs_l.right_px[il] if right_end else runs_l.left_px[il]
    ir = runs_r.find(rows, el - d - sgn * 1.0)
    near = ir >= 0
    if outvote:       # (rows whose right run lies further in: only for the rows' own vote)
        ir = np.where(near, ir, runs_r.find(rows, el - d - sgn * (1.0 + r)))
    er = np.where(ir >= 0, runs_r.right_px[ir] if right_end else runs_r.left_px[ir], np.nan)
    fin = np.isfinite(er)
    er[fin] = np.where(at_view_edge(rows[fin], er[fin], sgn, sm.valid_right, w), np.nan, er[fin])
    d_all = el - er
    de = d_all[near & (np.abs(d_all - d) <= 1.0)]
    if len(de) >= 3:
        d = float(median(de))
    elif outvote and np.isfinite(d_all).sum() >= 3:
        d_all = d_all[np.isfinite(d_all)]
        agree = d_all[np.abs(d_all - median(d_all)) <= 1.0]
        if len(agree) >= 3 and 2 * len(agree) > len(d_all):
            d = float(median(agree))
    return d - silhouette_offset_px(uv_edge[0], d, r, sgn, sm.f_px, cx)


def _blob_pair(rng, h=80, w=160):
    """A soft left mask of a few capsules (round caps, any direction, radii 1.5-8 px) and the right
    view's: the same moved by a disparity of 20-40 px, one capsule sometimes cut, widened or dropped
    (run ends of other lengths), anti-aliased; and the disparity."""
    d = float(rng.uniform(20, 40))
    left, right = np.zeros((h * 4, w * 4), np.uint8), np.zeros((h * 4, w * 4), np.uint8)
    for _ in range(int(rng.integers(1, 4))):
        a = rng.uniform([50, 5], [w - 5, h - 5])
        b = a + rng.uniform(-40, 40, 2)
        r = float(rng.uniform(1.5, 8))
        th = max(1, int(round(8 * r)))
        for img, shift in ((left, 0.0), (right, d)):
            pa, pb = np.round((a - (shift, 0)) * 4).astype(int), np.round((b - (shift, 0)) * 4).astype(int)
            if img is right and rng.random() < 0.3:
                th2 = th + int(rng.integers(-4, 8))
                cv2.line(img, tuple(map(int, pa)), tuple(map(int, pb)), 255, max(th2, 1))
            elif not (img is right and rng.random() < 0.1):
                cv2.line(img, tuple(map(int, pa)), tuple(map(int, pb)), 255, th)
    left, right = (cv2.resize(m, (w, h), interpolation=cv2.INTER_AREA) for m in (left, right))
    return left, right, d


def _placer(left, right, valid_r=None, valid_l=None):
    sm = SimpleNamespace(left_mask=left, right_mask=right, valid_left=valid_l, valid_right=valid_r, f_px=F_PX,
                         d_range_px=(10.0, 60.0))
    return SimpleNamespace(sm=sm, runs_l=find_runs(left, soft=True), runs_r=find_runs(right, soft=True))


def test_cap_shapes_offsets_is_the_remap_reads_bit_for_bit():
    """Random ends on and off anti-aliased capsules (caps seen whole, cut, touching the image's
    edge; ends off the mask, never leaving it): the same readings (or None) and offsets, bit for bit."""
    rng = np.random.default_rng(0)
    n_read = 0
    for trial in range(60):
        left, _, _ = _blob_pair(rng)
        on = np.argwhere(left >= 128)
        ends_ = []
        for _ in range(8):
            y, x = on[rng.integers(len(on))] if len(on) and rng.random() < 0.8 else rng.uniform(0, 80, 2)
            a = rng.uniform(0, 2 * np.pi)
            ends_.append((np.array([x, y], float) + rng.uniform(-1, 1, 2), np.array([np.cos(a), np.sin(a)]),
                          float(rng.uniform(1.0, 9.0))))
        got = tips.cap_shapes_offsets(left, ends_)
        want = _ref_cap_shapes_offsets(left, ends_)
        assert repr(got[0]) == repr(want[0])
        np.testing.assert_array_equal(got[1], want[1])
        n_read += sum(s is not None and s[0] is not None for s in got[0])
    assert n_read > 60


def test_cap_fit_gives_caps_cap_disparity_bit_for_bit():
    """Random patches over random capsule pairs (caps and bodies, repeated caps along the rows with
    textured and flat grey images, patches leaving the image, a right view cut by its valid area, any
    direction, two margins): caps.cap_disparity with the kernel gives the former numpy steps' disparity
    or None, bit for bit."""
    rng = np.random.default_rng(3)
    n_val = n_rival = 0
    for trial in range(80):
        left, right, d = _blob_pair(rng)
        h, w = left.shape
        grey_l = rng.integers(0, 255, (h, w)).astype(np.uint8) if trial % 2 else np.full((h, w), 90, np.uint8)
        grey_r = np.roll(grey_l, -int(round(d)), axis=1)
        valid_r = None
        if trial % 3 == 0:
            valid_r = np.ones((h, w), bool)
            valid_r[:, :int(rng.integers(1, 60))] = False
        sm = SimpleNamespace(left_mask=left, right_mask=right, left_gray=grey_l, right_gray=grey_r, valid_right=valid_r,
                             d_range_px=(float(rng.uniform(2, 15)), float(rng.uniform(40, 80))))
        on = np.argwhere(left >= 128)
        for _ in range(6):
            y, x = on[rng.integers(len(on))] if len(on) and rng.random() < 0.85 else rng.uniform(0, 80, 2)
            a = rng.uniform(0, 2 * np.pi)
            centre, out = np.array([x, y], float) + rng.uniform(-1, 1, 2), np.array([np.cos(a), np.sin(a)])
            half_px, margin = int(rng.integers(4, 14)), float(rng.choice([caps.MIN_FIT_MARGIN, 0.08]))
            want = _ref_cap_disparity(sm, centre, half_px, out, margin)
            assert caps.cap_disparity(sm, centre, half_px, out, margin) == want
            n_val += want is not None
            ok, *_, rivals, _ = kernels_tips.cap_fit(left, right, centre[0], centre[1], half_px, out[0], out[1],
                                                     *sm.d_range_px, caps.FAR_CANDIDATES, caps.MAX_FIT_ERROR, margin)
            n_rival += bool(ok and len(rivals))
    assert n_val > 40 and n_rival > 5


def test_cap_disparity_kernel_is_the_numpy_rows_at_rounding_level():
    """Random caps' rows over random capsule pairs (rows on and off the runs, valid areas cutting the
    view, split rows): the same None / NaN, disparities within 1e-9 px (numpy's vectorised
    trigonometry against libm's)."""
    rng = np.random.default_rng(1)
    n_val = n_none = n_edge = 0
    for trial in range(150):
        left, right, d = _blob_pair(rng)
        h, w = left.shape
        valid_l, valid_r = np.ones((h, w), bool), np.ones((h, w), bool)
        valid_l[:, :int(rng.integers(0, 8))] = False
        valid_r[:, w - int(rng.integers(1, 30)):] = False
        b = _placer(left, right, valid_r, valid_l)
        rl, rr = kernels_tips.runs_tables(b.runs_l), kernels_tips.runs_tables(b.runs_r)
        vl, vr = kernels_tips.valid_table(valid_l), kernels_tips.valid_table(valid_r)
        for _ in range(6):
            k = int(rng.integers(len(b.runs_l.row))) if len(b.runs_l.row) else 0
            p = np.array([b.runs_l.centre_px[k] if len(b.runs_l.row) else 50.0,
                          (b.runs_l.row[k] if len(b.runs_l.row) else 40) + rng.uniform(-1, 1)])
            a = rng.uniform(0, 2 * np.pi)
            out, r = np.array([np.cos(a), np.sin(a)]), float(rng.uniform(1.5, 8.0))
            rows = np.arange(int(np.ceil(p[1] - r)), int(np.floor(p[1] + r)) + 1)
            rows = rows[(rows >= 0) & (rows < h)]
            s = p[0] + (rows - p[1]) * rng.uniform(-0.5, 0.5) + rng.normal(0, 0.5, len(rows))
            d_prior = d + float(rng.normal(0, 1.0))
            # (and a prior 3-10 px off: the cap's edge rows alone, tipends.OWN_EDGE_ROWS)
            for prior in (d_prior, d + float(rng.choice([-1.0, 1.0]) * rng.uniform(3.0, 10.0))):
                want = _ref_cap_disparity_rows(rows, s, b.runs_l, b.runs_r, valid_l, valid_r, p, out, r, prior, h, w)
                status, got = kernels_tips.cap_disparity(rows.astype(np.int64), s, rl, rr, vl, vr, p[0], p[1], out[0],
                                                         out[1], r, prior, F_PX, h, w, CAP_EDGE_BACK,
                                                         tips.SPLIT_ROW_PX, *CAP_SPLIT_PX, CAP_SPLIT_SHARE,
                                                         OWN_CAP_ROWS, OWN_CAP_PX, OWN_EDGE_ROWS, OWN_EDGE_PX,
                                                         OWN_EDGE_SHARE, OWN_EDGE_WIDTH)
                if want is None:
                    assert status == 0
                    n_none += 1
                elif np.isnan(want):
                    assert status == 2
                else:
                    assert status == 1
                    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)     # px
                    n_val += 1
                    n_edge += _ref_cap_disparity_rows(rows, s, b.runs_l, b.runs_r, valid_l, valid_r, p, out, r, prior,
                                                      h, w, edge_rows=0) is None
    assert n_val > 150 and n_none > 50 and n_edge > 10


def test_end_disparity_and_outline_kernels_are_the_numpy_steps():
    """Random flat ends (both directions, inside offsets, radii below and above 2 px, priors near and
    far, a right view cut by its valid area) over random capsule pairs: the same None, disparities
    within 1e-9 px, the same outline decisions."""
    rng = np.random.default_rng(2)
    n_val = n_ol = 0
    for trial in range(150):
        left, right, d = _blob_pair(rng)
        h, w = left.shape
        valid_r = None
        if trial % 2:
            valid_r = np.ones((h, w), bool)
            valid_r[:, :int(rng.integers(1, 40))] = False
        b = _placer(left, right, valid_r)
        if not len(b.runs_l.row):
            continue
        for _ in range(8):
            k = int(rng.integers(len(b.runs_l.row)))
            right_end = rng.random() < 0.5
            x = (b.runs_l.right_px if right_end else b.runs_l.left_px)[k] + rng.uniform(-1.5, 1.5)
            uv_edge = np.array([x, b.runs_l.row[k] + rng.uniform(-0.5, 0.5)])
            a = rng.uniform(-0.6, 0.6)
            out = np.array([np.cos(a), np.sin(a)]) * (1 if right_end else -1)
            r, d_prior = float(rng.choice([0.0, 1.2, rng.uniform(1.5, 8)])), d + float(rng.normal(0, 1.5))
            inside = float(rng.choice([1.0, 0.5 * max(r, 1.0)]))
            want = _ref_end_disparity(b, uv_edge, out, d_prior, r, inside)
            got = EndPlacer._end_disparity(b, uv_edge, out, d_prior, r, inside)
            assert (got is None) == (want is None)
            if want is not None:
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)     # px
                n_val += 1
            d_try = d + float(rng.normal(0, 1.0))
            r_ol = max(r, 1.0)
            want_ol = _ref_end_outline_agrees(b, uv_edge, out, d_try, r_ol)
            assert EndPlacer._end_outline_agrees(b, uv_edge, out, d_try, r_ol) is want_ol
            n_ol += want_ol
    assert n_val > 200 and n_ol > 50


def test_end_disparity_kernel_is_the_numpy_steps_where_rows_outvote_the_axis_row():
    """Flat ends of random capsule pairs whose right view bulges 1-3 px past the end on 1-2 rows near them (the rows'
    vote of tipends.END_ROWS_OUTVOTE): the kernel's disparity is the numpy steps' within 1e-9 px, and the vote
    changes some of them."""
    rng = np.random.default_rng(5)
    n_val = n_voted = 0
    for trial in range(60):
        left, right, d = _blob_pair(rng)
        b0 = _placer(left, right)
        if not len(b0.runs_l.row):
            continue
        for _ in range(6):
            k = int(rng.integers(len(b0.runs_l.row)))
            right_end = rng.random() < 0.5
            e = (b0.runs_l.right_px if right_end else b0.runs_l.left_px)[k]
            row = int(b0.runs_l.row[k])
            bulged = right.copy()
            x = int(round(e - d))
            step = int(rng.integers(1, 4))
            rows = slice(row, row + int(rng.integers(1, 3)))
            if right_end:
                bulged[rows, max(x + 1, 0):x + 1 + step] = 255
            else:
                bulged[rows, max(x - step, 0):max(x, 0)] = 255
            b = _placer(left, bulged)
            a = rng.uniform(-0.3, 0.3)
            out = np.array([np.cos(a), np.sin(a)]) * (1 if right_end else -1)
            uv_edge = np.array([e + 0.5 * out[0], row - out[1] * 4.0])
            r, d_prior = float(rng.uniform(4, 8)), d + float(rng.normal(0, 1.0))
            want = _ref_end_disparity(b, uv_edge, out, d_prior, r, 1.0, outvote=True)
            got = EndPlacer._end_disparity(b, uv_edge, out, d_prior, r, 1.0)
            assert (got is None) == (want is None)
            if want is not None:
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)     # px
                n_val += 1
                n_voted += abs(want - _ref_end_disparity(b, uv_edge, out, d_prior, r, 1.0, outvote=False)) > 0.5
    assert n_val > 200 and n_voted > 30


def test_kernels_take_tips_constants():
    """The constants the kernels repeat are tips.py's."""
    assert kernels_tips.CAP_WIDTH_BACK == tips.CAP_WIDTH_BACK
    assert kernels_tips.ROUND_BACK == 1.0 - np.sqrt(0.51) == 1.0 - math.sqrt(0.51)
    assert END_RUN_CUT_PX == 2.0 and len(CAP_SPLIT_PX) == 2
