"""The feature check's kernel (localize/kernels_check.py, speedG) against the numpy code it replaced
(kept here as the reference: featurecheck._patches and _patch_size before the pass)."""

from __future__ import annotations

import numpy as np
from appliance.localize import featurecheck
from appliance.localize import featurecheck as FC
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
    """featurecheck._patches before the kernel (speedG): every feature's patches along its pieces, all at once: a dict of arrays (P,) ``feature``, ``piece``,
    ``s`` (px from the feature along the piece), ``u``, ``v`` (int centre), ``d_ref`` (the disparity searched
    around: the feature's), ``hh``, ``hw`` (int half height, width), ``across`` (half extent across the axis,
    px), ``r`` (the piece's radius px), ``slope`` (the piece's disparity slope over the patches' reach, px per
    px, away from the feature). A fork's patches start clear of its other pieces' silhouettes
    (``FC.FORK_CLEAR`` x their largest radius), a tip's ``FC.TIP_BACK`` radius back; patches inside the image and
    the left mask only; pieces turning steeply in depth (``|slope| > FC.MAX_PIECE_SLOPE``) or too short give none."""
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
