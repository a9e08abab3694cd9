"""The feature check's kernels (localize/kernels_check.py, speedG) against the numpy code they replaced
(kept here as the reference: featurecheck._patches, _patch_size and estimate before the pass)."""

from __future__ import annotations

import numpy as np

from appliance.localize import featurecheck, featurecheck as FC
from appliance.localize.matching import FeatureUVD, PieceUVD


def _patch_size(radius_px: np.ndarray, du: np.ndarray, dv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Half heights, half widths (px) (K,) int of patches inside branches of ``radius_px`` (K,) running along
    (``du``, ``dv``) (K,) (unit), and their half extents across the branch (K,) px: long along the rows on
    a flat branch (< 30 deg), narrow across a steep one (> 60 deg), a square inside the branch otherwise."""
    r = np.maximum(radius_px, 1.0)
    a = np.abs(dv)                                           # sine of the angle to the rows
    flat, steep = a < 0.5, a > 0.87
    sq = np.clip(np.rint(0.45 * r), 2, 6)
    hh = np.where(flat, np.clip(np.floor(0.6 * r), 1, 7), np.where(steep, 4, sq)).astype(np.int64)
    hw = np.where(flat, 7, np.where(steep, np.clip(np.rint(0.6 * r), 2, 7), sq)).astype(np.int64)
    return hh, hw, hh * np.abs(du) + hw * a                  # (the box's half extent across the axis)


def _patches_numpy(features: list, pieces: list, left_mask: np.ndarray) -> dict:
    """featurecheck._patches before the kernel (speedG): every feature's patches along its pieces, all at
    once (the same columns as featurecheck._patches)."""
    fa = np.array([(ft.node, ft.u, ft.v, ft.d, ft.radius_px, ft.kind == "bifurcation") for ft in features],
                  float).reshape(-1, 6)
    fi, pj, r_other = featurecheck._pairs(fa, pieces)
    cols = ("feature", "piece", "s", "u", "v", "d_ref", "hh", "hw", "across", "r", "slope")
    if len(fi) == 0:
        return {c: np.zeros(0, np.int64 if c in ("feature", "piece", "u", "v", "hh", "hw") else float) for c in cols}
    used = np.unique(pj)
    # the used pieces' samples end to end, each piece's arc length from its first sample, pieces BIG px apart
    uvd = np.concatenate([pieces[j].uvd for j in used.tolist()]).astype(float)
    n = np.array([len(pieces[j].uvd) for j in used.tolist()])
    first = np.r_[0, np.cumsum(n)[:-1]]
    step = np.r_[0.0, np.hypot(np.diff(uvd[:, 0]), np.diff(uvd[:, 1]))]
    step[first] = 0.0
    arc = np.cumsum(step)
    arc -= np.repeat(arc[first], n)
    length = arc[first + n - 1]
    big = float(length.max()) + 10.0
    x = arc + np.repeat(np.arange(len(used)) * big, n)          # (increasing over all pieces)
    k = np.searchsorted(used, pj)                               # each pair's piece among the used
    ft_uv = fa[fi, 1:3]
    a, z = uvd[first[k], :2], uvd[first[k] + n[k] - 1, :2]
    from_end = np.hypot(*(z - ft_uv).T) < np.hypot(*(a - ft_uv).T)     # the feature at the piece's last sample
    r = np.maximum(np.array([pieces[j].radius_px for j in pj.tolist()], float), 1.0)
    fork = fa[fi, 5] > 0
    s0 = np.maximum(np.where(fork, FC.FORK_CLEAR * r_other, FC.TIP_BACK * r), FC.MIN_REACH_PX)
    s1 = np.minimum(s0 + np.clip(FC.REACH_RADII * r, FC.MIN_SPAN_PX, FC.MAX_SPAN_PX), length[k])
    dstep = np.clip(FC.STEP_RADII * r, FC.MIN_STEP_PX, FC.MAX_STEP_PX)

    # the piece's slope: least squares over 9 points of [s0 - r, max(s1, s0 + FC.MIN_SPAN_PX)] (within the piece);
    # the patches at s0, s0 + step, ... up to s1, and 1 px either side of them (their direction)
    lo = np.maximum(s0 - r, 0.0)
    hi = np.minimum(np.maximum(s1, s0 + FC.MIN_SPAN_PX), length[k])
    qs = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, 9)[None, :]
    m = int(FC.MAX_SPAN_PX // FC.MIN_STEP_PX) + 1
    q = s0[:, None] + dstep[:, None] * np.arange(m)[None, :]
    arcs = np.concatenate([qs, q, q + 1.0, q - 1.0], axis=1)      # (pairs, 9 + 3 m) px from the feature's end
    lk = length[k][:, None]
    xq = np.clip(np.where(from_end[:, None], lk - arcs, arcs), 0.0, lk) + (k * big)[:, None]
    dq = np.interp(xq[:, :9], x, uvd[:, 2])
    iu, iv = np.interp(xq[:, 9:], x, uvd[:, 0]), np.interp(xq[:, 9:], x, uvd[:, 1])
    qc = qs - qs.mean(1, keepdims=True)
    slope = (qc * (dq - dq.mean(1, keepdims=True))).sum(1) / np.maximum((qc * qc).sum(1), 1e-9)
    ok_pair = (s1 >= s0) & (hi - lo >= 2.0) & (np.abs(slope) <= FC.MAX_PIECE_SLOPE)
    valid = ok_pair[:, None] & (q <= s1[:, None] + 1e-9)
    pu, pv = iu[:, :m], iv[:, :m]
    du, dv = iu[:, m:2 * m] - iu[:, 2 * m:], iv[:, m:2 * m] - iv[:, 2 * m:]
    pair, col = np.nonzero(valid)
    ln = np.maximum(np.hypot(du, dv), 1e-9)[pair, col]
    rr = r[pair]
    hh, hw, across = _patch_size(rr, du[pair, col] / ln, dv[pair, col] / ln)
    ui, vi = np.rint(pu[pair, col]).astype(np.int64), np.rint(pv[pair, col]).astype(np.int64)
    h, w = left_mask.shape
    keep = (vi >= hh) & (vi < h - hh) & (ui >= hw) & (ui < w - hw)
    # inside the branch (not a leaf, not the background): the box's corners, edge midpoints and centre
    yy = np.clip(vi[:, None] + np.array([-1, -1, -1, 0, 0, 0, 1, 1, 1]) * hh[:, None], 0, h - 1)
    xx = np.clip(ui[:, None] + np.array([-1, 0, 1, -1, 0, 1, -1, 0, 1]) * hw[:, None], 0, w - 1)
    keep &= (left_mask[yy, xx] >= 128).all(1)
    pair, col = pair[keep], col[keep]
    d_feat = fa[fi, 3]
    return {"feature": fi[pair], "piece": pj[pair], "s": q[pair, col], "u": ui[keep], "v": vi[keep],
            "d_ref": d_feat[pair], "hh": hh[keep], "hw": hw[keep], "across": across[keep], "r": rr[keep],
            "slope": slope[pair]}


def _estimate_numpy(t: dict, d_px: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """featurecheck.estimate before the kernel (speedG): the texture's disparity at each feature from the
    patch table ``t`` (:func:`patch_table`; rows grouped by feature, then piece) and the features'
    disparities ``d_px`` (F,).

    A piece's confident patches (``score >= FC.MIN_SCORE``, at least ``FC.MIN_PATCHES``) are carried to the feature
    along a slope. Where they lie on a straight line of their own (at least ``FC.FIT_MIN_PATCHES`` spanning
    ``FC.FIT_MIN_SPAN_PX``, none off it by more than ``FC.FIT_MAX_RES_PX``, its slope within ``FC.MAX_PIECE_SLOPE``)
    the slope is the texture's or the matched piece's: the two lines through the patches' centroid bound
    the piece's estimate at the feature, and the bound nearer the feature's disparity counts (none when
    the feature's lies between them). Otherwise they are carried along the piece's slope and their mean
    counts when they agree within ``2 FC.MAX_SPREAD_PX``. The feature's estimate is the piece estimate
    nearest its disparity when all lie on one side of it, its own disparity (agreement) when they
    straddle it: the least alarming reading of the texture.

    Returns
    -------
    d_check, n, spread : ndarray (F,)
        The estimate (NaN: no verdict), the confident patches of the pieces that gave one (int), and the
        largest spread (max - min, px) of their values carried along the pieces' slopes.
    """
    nf = len(d_px)
    d_check, n_used, spread = np.full(nf, np.nan), np.zeros(nf, np.int64), np.full(nf, np.nan)
    good = np.isfinite(t["d_axis"]) & (t["score"] >= FC.MIN_SCORE)
    if not good.any():
        return d_check, n_used, spread
    f, p, s, d, g = (t[c][good] for c in ("feature", "piece", "s", "d_axis", "slope"))
    key = f * (int(p.max()) + 1) + p
    starts = np.r_[0, np.flatnonzero(np.diff(key)) + 1]
    cnt = np.diff(np.r_[starts, len(key)])
    grp = np.repeat(np.arange(len(starts)), cnt)
    fg = f[starts]                                           # each group's feature
    # carried along the piece's slope
    e = d - g * s
    e_lo, e_hi = np.minimum.reduceat(e, starts), np.maximum.reduceat(e, starts)
    carry = np.where((cnt >= FC.MIN_PATCHES) & (e_hi - e_lo <= 2 * FC.MAX_SPREAD_PX), np.add.reduceat(e, starts) / cnt,
                     np.nan)
    # the texture's own straight line
    s1, s2 = np.add.reduceat(s, starts), np.add.reduceat(s * s, starts)
    y1, sy = np.add.reduceat(d, starts), np.add.reduceat(s * d, starts)
    den = cnt * s2 - s1 * s1
    b = (cnt * sy - s1 * y1) / np.where(den > 0, den, 1.0)
    a0 = (y1 - b * s1) / cnt
    res = np.maximum.reduceat(np.abs(d - a0[grp] - b[grp] * s), starts)
    span = np.maximum.reduceat(s, starts) - np.minimum.reduceat(s, starts)
    line = ((cnt >= FC.FIT_MIN_PATCHES) & (span >= FC.FIT_MIN_SPAN_PX) & (res <= FC.FIT_MAX_RES_PX)
            & (np.abs(b) <= FC.MAX_PIECE_SLOPE))
    # on the texture's line the slope is the texture's or the piece's: the intercepts of both lines through the
    # patches' centroid bound the estimate; the bound nearer the feature's disparity counts (0 between them)
    a_piece = (y1 - g[starts] * s1) / cnt
    lo_b, hi_b = np.minimum(a0, a_piece) - d_px[fg], np.maximum(a0, a_piece) - d_px[fg]
    on_line = np.where(lo_b > 0, lo_b, np.where(hi_b < 0, hi_b, 0.0))
    diff = np.where(line, on_line, carry - d_px[fg])                 # (NaN: neither)
    ok = np.isfinite(diff)
    if not ok.any():
        return d_check, n_used, spread
    fg, diff, cnt, ext = fg[ok], diff[ok], cnt[ok], (e_hi - e_lo)[ok]
    fs = np.r_[0, np.flatnonzero(np.diff(fg)) + 1]
    lo, hi = np.minimum.reduceat(diff, fs), np.maximum.reduceat(diff, fs)
    fi = fg[fs]
    d_check[fi] = d_px[fi] + np.where(lo > 0, lo, np.where(hi < 0, hi, 0.0))
    n_used[fi] = np.add.reduceat(cnt, fs)
    spread[fi] = np.maximum.reduceat(ext, fs)
    return d_check, n_used, spread


def _scene(rng: np.random.Generator, n_pieces: int, h: int = 120, w: int = 160):
    """Random pieces (polylines with repeated samples, straight and turning, flat and sloping in
    disparity, some recovered or too short), features at their ends (tips; forks where 2-3 pieces
    meet), and a left mask covering most of the image with holes."""
    pieces, features = [], []
    node = 0
    for i in range(n_pieces):
        n = int(rng.integers(1, 40))
        start = rng.uniform([-10, -10], [w + 10, h + 10])
        turn = rng.normal(0, 0.15 if i % 2 else 0.01)
        ang = rng.uniform(0, 2 * np.pi) + turn * np.arange(n)
        step = rng.choice([0.0, 0.7, 1.0, 2.5], n, p=[0.1, 0.3, 0.4, 0.2])
        uv = start + np.cumsum(np.stack([np.cos(ang), np.sin(ang)], 1) * step[:, None], 0)
        d = 40 + rng.choice([0.0, 0.02, 0.3]) * np.arange(n) + rng.normal(0, 0.05, n)
        a = node if i % 3 == 0 or not pieces else pieces[-1].nodes[1]     # (every third piece starts a new node)
        pieces.append(PieceUVD(i, np.column_stack([uv, d]), float(rng.uniform(0.5, 12.0)), bool(rng.random() < 0.1),
                               (a, node + 1)))
        node += 2
        for nd, p in ((a, uv[0]), (node - 1, uv[-1])):
            if rng.random() < 0.8 and all(f.node != nd for f in features):
                kind = "bifurcation" if sum(nd in q.nodes for q in pieces) >= 2 else "endpoint"
                features.append(FeatureUVD(nd, kind, float(p[0]), float(p[1]), 40.0, float(rng.uniform(1, 8))))
    mask = np.full((h, w), 255, np.uint8)
    for _ in range(6):
        y, x = rng.integers(0, h), rng.integers(0, w)
        mask[max(y - 8, 0):y + 8, max(x - 8, 0):x + 8] = rng.choice([0, 127, 128])
    return features, pieces, mask


def test_patches_are_the_numpy_steps():
    """featurecheck._patches (kernels_check.place_patches) against the numpy steps it replaced on 300
    random scenes: every column bit for bit (centres, sizes, distances, slopes); patches are kept and
    dropped (image edges, mask holes, steep pieces) in both."""
    rng = np.random.default_rng(11)
    kept = total_pairs = 0
    for _ in range(300):
        features, pieces, mask = _scene(rng, int(rng.integers(1, 9)))
        want, got = _patches_numpy(features, pieces, mask), FC._patches(features, pieces, mask)
        assert want.keys() == got.keys()
        for c in want:
            assert want[c].dtype == got[c].dtype, c
            np.testing.assert_array_equal(got[c], want[c], err_msg=c)
        kept += len(got["u"])
        total_pairs += len(np.unique(got["feature"]))
    assert kept > 1000 and total_pairs > 200
    empty = FC._patches([], [], np.zeros((4, 4), np.uint8))
    assert all(len(v) == 0 for v in empty.values())


def _table(rng: np.random.Generator, nf: int):
    """A random patch table (rows grouped by feature, then piece; 0-14 patches a piece, some without a
    disparity or matched weakly, on a line, on a line with outliers, or scattered) and the features'
    disparities."""
    rows = {c: [] for c in ("feature", "piece", "s", "d_axis", "slope", "score")}
    d_px = rng.uniform(20, 200, nf)
    piece = 0
    for f in range(nf):
        for _ in range(int(rng.integers(0, 4))):
            n = int(rng.integers(0, 15))
            s = np.sort(rng.uniform(2, 45, n)) if rng.random() < 0.8 else np.full(n, 6.0)
            slope = rng.choice([0.0, 0.05, -0.1, 0.2]) * rng.random()
            base = d_px[f] + rng.choice([0.0, 0.3, 1.5, -2.5]) + rng.normal(0, 0.4)
            d = base + rng.choice([slope, -slope, 0.11, 0.02]) * s + rng.normal(0, rng.choice([0.01, 0.1, 0.6]), n)
            d[rng.random(n) < 0.1] = np.nan
            for c, v in (("feature", np.full(n, f)), ("piece", np.full(n, piece)), ("s", s), ("d_axis", d),
                         ("slope", np.full(n, slope)), ("score", rng.uniform(0.5, 1.0, n))):
                rows[c].append(v)
            piece += int(rng.integers(1, 3))
    t = {c: np.concatenate(v) if v else np.zeros(0) for c, v in rows.items()}
    t["feature"], t["piece"] = t["feature"].astype(np.int64), t["piece"].astype(np.int64)
    return t, d_px


def test_estimate_is_the_numpy_steps():
    """featurecheck.estimate (kernels_check.estimate_pieces) against the numpy steps it replaced on 600
    random patch tables: estimates, patch counts and spreads bit for bit (NaN where no verdict);
    features estimated by the texture's line, by the pieces' slope and with no verdict all occur."""
    rng = np.random.default_rng(12)
    verdicts = none = agree = 0
    for _ in range(600):
        t, d_px = _table(rng, int(rng.integers(1, 7)))
        want, got = _estimate_numpy(t, d_px), FC.estimate(t, d_px)
        for w_, g_ in zip(want, got):
            assert w_.dtype == g_.dtype
            np.testing.assert_array_equal(g_, w_)
        verdicts += np.isfinite(got[0]).sum()
        none += np.isnan(got[0]).sum()
        agree += (got[0] == d_px).sum()
    assert verdicts > 300 and none > 300 and agree > 100 and verdicts - agree > 100
