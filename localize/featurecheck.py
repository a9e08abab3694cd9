"""An independent check of each matched feature's disparity by the bark texture of its own branches.

The matcher places a tip or a fork from the branch outlines (and, on flat pieces, their texture) by
several mechanisms; each has its own ways to fail, and a feature grossly off in depth (seeds 260-291:
1-4 px of disparity, 6-18 mm) is worse for the arm than a feature not reported. This check knows none
of those mechanisms. Near each feature it takes small patches of the left grey image inside the
feature's branch(es) (a tip: its branch ``TIP_REACH`` radii back from the tip; a fork: each of its
pieces, clear of the crotch), finds each patch's disparity in the right image along the same
rectified row by normalised cross-correlation (:func:`kernels.ncc_peaks`: exact integer sums,
sub-pixel parabola), moves it from the bark surface back onto the axis
(:func:`texture.surface_to_axis`) and carries it to the feature along the piece's own disparity
slope (a branch turning in depth changes disparity along its length). Where enough patches agree
with each other and their median differs from the feature's disparity by more than ``max_diff_px``,
the feature is withheld. Patches without texture, off the branch or matched weakly give no verdict:
the feature is kept.
Measured on 60 scenes and seeds 260-291: docs/localize-featurecheck.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from appliance.localize import kernels
from appliance.localize.texture import surface_to_axis

TIP_BACK = 1.0               # a tip's patches start this many radii back along its branch
FORK_CLEAR = 1.2             # a fork's start this many of its other pieces' largest radius out (clear of them)
REACH_RADII = 3.0            # ... and span this many radii of the piece
MIN_SPAN_PX, MAX_SPAN_PX = 20.0, 40.0    # ... but at least / at most this many px
STEP_RADII = 0.75            # one patch every this many radii
MIN_STEP_PX, MAX_STEP_PX = 3.0, 8.0
MIN_REACH_PX = 4.0           # patches start at least this far from the feature
WINDOW_PX = 8                # each patch searched within +-this of the piece's disparity there
MIN_SCORE = 0.7              # a patch matched with a lower correlation gives no verdict
MIN_STD = 2.0                # a patch with a lower grey-level standard deviation has no texture
MIN_PATCHES = 2              # fewer agreeing patches give no verdict
MAX_SLOPE = 0.1              # the search window widens by this many px per px from the feature
MAX_PIECE_SLOPE = 0.06      # a piece whose disparity changes faster (px per px) gives no verdict
MAX_SPREAD_PX = 0.5          # a piece whose patches disagree by more than twice this (px) gives no verdict


@dataclass(frozen=True)
class FeatureCheck:
    """One feature's texture check.

    Attributes
    ----------
    node : int
        The feature's graph node.
    d_px : float
        The feature's (matched) disparity.
    d_check_px : float
        The texture's disparity carried to the feature (median over its patches; NaN: no verdict).
    n_patches : int
        Patches that gave a confident disparity.
    spread_px : float
        Their median absolute deviation (px).
    withheld : bool
        ``|d_check_px - d_px| > max_diff_px`` with enough agreeing patches.
    """

    node: int
    d_px: float
    d_check_px: float
    n_patches: int
    spread_px: float
    withheld: bool

    @property
    def diff_px(self) -> float:
        """Texture minus feature disparity (NaN: no verdict)."""
        return self.d_check_px - self.d_px


def _along(uvd: np.ndarray, u: float, v: float) -> tuple[np.ndarray, np.ndarray]:
    """A piece's samples (N, 3) ordered from the end nearer (``u``, ``v``) and their arc length (N,) px
    in the image from that end."""
    if np.hypot(uvd[-1, 0] - u, uvd[-1, 1] - v) < np.hypot(uvd[0, 0] - u, uvd[0, 1] - v):
        uvd = uvd[::-1]
    step = np.hypot(np.diff(uvd[:, 0]), np.diff(uvd[:, 1]))
    return uvd, np.r_[0.0, np.cumsum(step)]


def _patch_size(radius_px: float, du: np.ndarray, dv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Half heights, half widths (px) (K,) int of patches inside a branch of ``radius_px`` running along
    (``du``, ``dv``) (K,) (unit), and their half extents across the branch (K,) px: long along the rows on
    a flat branch (< 30 deg), narrow across a steep one (> 60 deg), a square inside the branch otherwise."""
    r = max(radius_px, 1.0)
    a = np.abs(dv)                                           # sine of the angle to the rows
    flat, steep = a < 0.5, a > 0.87
    sq = max(2, min(6, round(0.45 * r)))
    hh = np.where(flat, max(1, min(7, int(0.6 * r))), np.where(steep, 4, sq))
    hw = np.where(flat, 7, np.where(steep, max(2, min(7, round(0.6 * r))), sq))
    return hh, hw, hh * np.abs(du) + hw * a                  # (the box's half extent across the axis)


def check_features(features: list, pieces: list, left, right, left_mask: np.ndarray,
                   d_range_px: tuple[float, float], f_px: float, offset_px: float = 0.0,
                   max_diff_px: float = 1.0) -> list[FeatureCheck]:
    """The texture check of every feature (see module docstring).

    Parameters
    ----------
    features : list of matching.FeatureUVD
        Matched features (rectified left (u, v), disparity d, radius px).
    pieces : list of matching.PieceUVD
        Matched branch pieces; a feature's patches lie on the (not recovered) pieces ending at its node.
    left, right : ndarray (H, W) uint8 or lazy rectified images
        Rectified grey images (read in small boxes: ``img[y0:y1, x0:x1]``).
    left_mask : ndarray (H, W) uint8
        Left branch coverage 0-255; a patch must lie where it is >= 128 throughout.
    d_range_px : (float, float)
        Disparities of the working range (patches are searched within them).
    f_px, offset_px : float
        Rectified focal length and ``cx_left - cx_right``.
    max_diff_px : float
        A feature whose texture disparity differs by more is withheld.

    Returns
    -------
    list of FeatureCheck
        One per feature, in order.
    """
    t = patch_table(features, pieces, left, right, left_mask, d_range_px, f_px, offset_px)
    out = []
    for i, ft in enumerate(features):
        sel = t["feature"] == i
        dc, n, spread = estimate(t["s"][sel], t["d_axis"][sel], t["score"][sel], t["piece"][sel], t["slope"][sel],
                                 ft.d)
        withheld = bool(n >= MIN_PATCHES and abs(dc - ft.d) > max_diff_px)
        out.append(FeatureCheck(int(ft.node), float(ft.d), dc, n, spread, withheld))
    return out


def patch_table(features: list, pieces: list, left, right, left_mask: np.ndarray, d_range_px, f_px: float,
                offset_px: float) -> dict:
    """Every feature's patches and their texture disparity: a dict of arrays (P,): ``feature`` (index),
    ``piece`` (index among all pieces), ``s`` (px from the feature along the piece), ``u``, ``v``,
    ``d_axis`` (the patch's texture disparity moved onto the axis; NaN: none), ``score``."""
    by_node: dict[int, list] = {}
    for j, p in enumerate(pieces):
        if p.recovered or len(p.uvd) < 2 or not np.isfinite(p.radius_px):
            continue
        for n in set(p.nodes):
            by_node.setdefault(int(n), []).append(j)
    h, w = left_mask.shape
    rows = []
    for i, ft in enumerate(features):
        js = by_node.get(int(ft.node), [])
        for j in js:
            r_other = max([pieces[k].radius_px for k in js if k != j], default=ft.radius_px)
            rows += _piece_patches(i, j, ft, pieces[j], r_other, left_mask)
    cols = ("feature", "piece", "s", "u", "v", "d_ref", "hh", "hw", "across", "r", "slope")
    a = np.array(rows, float).reshape(-1, len(cols))
    t = {c: a[:, k] for k, c in enumerate(cols)}
    for c in ("feature", "piece", "u", "v", "hh", "hw"):
        t[c] = t[c].astype(np.int64)
    d_surf, t["score"] = patch_disparities(left, right, t, d_range_px, w)
    frac = patch_depth_fraction_many(t["r"], t["across"])
    t["d_axis"] = surface_to_axis(d_surf, t["r"], f_px, offset_px, frac)
    return t


def patch_depth_fraction_many(radius_px: np.ndarray, across_px: np.ndarray) -> np.ndarray:
    """:func:`texture.patch_depth_fraction` of patches (P,) spanning +-``across_px`` across branches of
    ``radius_px``: the mean of sqrt(1 - (y / r)^2) over whole-px offsets y."""
    k = np.maximum(np.asarray(across_px, float).astype(int), 1)
    if len(k) == 0:
        return np.zeros(0)
    y = np.arange(-k.max(), k.max() + 1, dtype=float)
    inside = np.abs(y)[None, :] <= k[:, None]
    t = y[None, :] / np.maximum(radius_px, 1e-9)[:, None]
    val = np.sqrt(np.clip(1.0 - t * t, 0.0, None))
    return (val * inside).sum(1) / inside.sum(1)


def _piece_patches(i: int, j: int, ft, p, r_other: float, left_mask: np.ndarray) -> list:
    """Patch rows ``(feature, piece, s, u, v, d_ref, hh, hw, across, r, slope)`` along one piece of a feature
    (inside the image and the left mask); ``d_ref`` the disparity each patch is searched around, ``slope``
    the piece's disparity slope (px per px) over the patches' reach. A fork's patches start clear of the
    other pieces' silhouettes (``r_other``: their largest radius, px), a tip's one radius back."""
    uvd, s = _along(p.uvd, ft.u, ft.v)
    r = max(float(p.radius_px), 1.0)
    s0 = max(FORK_CLEAR * r_other if ft.kind == "bifurcation" else TIP_BACK * r, MIN_REACH_PX)
    s1 = min(s0 + min(max(REACH_RADII * r, MIN_SPAN_PX), MAX_SPAN_PX), s[-1])
    if s1 < s0:
        return []
    near = (s >= s0 - r) & (s <= max(s1, s0 + MIN_SPAN_PX) + 1.0)     # the piece's slope over the patches' reach
    sn, dn = s[near], uvd[near, 2]
    if len(sn) < 2 or np.ptp(sn) < 2.0:
        return []
    sc = sn - sn.mean()
    g = float((sc * (dn - dn.mean())).sum() / (sc * sc).sum())
    if abs(g) > MAX_PIECE_SLOPE:                         # (turning steeply in depth: no verdict)
        return []
    sk = np.arange(s0, s1 + 1e-9, min(max(STEP_RADII * r, MIN_STEP_PX), MAX_STEP_PX))
    q = np.concatenate([sk, sk + 1.0, sk - 1.0])
    uq, vq = np.interp(q, s, uvd[:, 0]), np.interp(q, s, uvd[:, 1])
    k = len(sk)
    du, dv = uq[k:2 * k] - uq[2 * k:], vq[k:2 * k] - vq[2 * k:]
    ln = np.maximum(np.hypot(du, dv), 1e-9)
    hh, hw, across = _patch_size(r, du / ln, dv / ln)
    ui, vi = np.rint(uq[:k]).astype(np.int64), np.rint(vq[:k]).astype(np.int64)
    h, w = left_mask.shape
    ok = (vi >= hh) & (vi < h - hh) & (ui >= hw) & (ui < w - hw)
    ui, vi, hh, hw, across, sk = ui[ok], vi[ok], hh[ok], hw[ok], across[ok], sk[ok]
    # inside the branch (not a leaf, not the background): the box's corners, edge midpoints and centre
    inside = np.ones(len(ui), bool)
    for fy, fx in ((-1, -1), (-1, 1), (1, -1), (1, 1), (0, -1), (0, 1), (-1, 0), (1, 0), (0, 0)):
        inside &= left_mask[vi + fy * hh, ui + fx * hw] >= 128
    m = int(inside.sum())
    return np.column_stack([np.full(m, i), np.full(m, j), sk[inside], ui[inside], vi[inside], np.full(m, ft.d),
                            hh[inside], hw[inside], across[inside], np.full(m, r), np.full(m, g)]).tolist()


def patch_disparities(left, right, t: dict, d_range_px: tuple[float, float], w: int) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel disparity (P,) of the bark surface of each patch of the table ``t`` (:func:`patch_table`'s
    columns ``feature``, ``u``, ``v``, ``d_ref``, ``hh``, ``hw``, ``s``; NaN: no texture, or the peak at the
    window's end) within ``d_ref`` +- (``WINDOW_PX`` + ``MAX_SLOPE`` x ``s``) (and the working range), and
    its correlation (P,). Each feature's patches are read in one box of each image."""
    n = len(t["u"])
    d_out, score = np.full(n, np.nan), np.full(n, -1.0)
    if n == 0:
        return d_out, score
    u, v, hh, hw = t["u"], t["v"], t["hh"], t["hw"]
    half = WINDOW_PX + MAX_SLOPE * t["s"]
    lo = np.maximum(np.floor(t["d_ref"] - half), math.floor(d_range_px[0])).astype(np.int64)
    hi = np.minimum(np.ceil(t["d_ref"] + half), math.ceil(d_range_px[1])).astype(np.int64)
    sx0, sx1 = np.maximum(u - hi - hw, 0), np.minimum(u - lo + hw + 1, w)
    cuts = np.flatnonzero(np.diff(t["feature"])) + 1                 # (rows are grouped by feature)
    for a, b in zip(np.r_[0, cuts].tolist(), np.r_[cuts, n].tolist()):
        y0, y1 = int((v[a:b] - hh[a:b]).min()), int((v[a:b] + hh[a:b]).max()) + 1
        lx0, lx1 = int((u[a:b] - hw[a:b]).min()), int((u[a:b] + hw[a:b]).max()) + 1
        rx0, rx1 = int(sx0[a:b].min()), int(sx1[a:b].max())
        lbox = np.ascontiguousarray(left[y0:y1, lx0:lx1])
        rbox = np.ascontiguousarray(right[y0:y1, rx0:rx1])
        for hw_k in np.unique(hw[a:b]).tolist():                     # (one call per patch width)
            i = a + np.flatnonzero(hw[a:b] == hw_k)
            ok, ks, offs, best = kernels.ncc_peaks(lbox, rbox, v[i] - y0, u[i] - lx0, hh[i], hw_k,
                                                   sx0[i] - rx0, sx1[i] - rx0, MIN_STD)
            inner = ok & (ks > 0) & (ks < sx1[i] - sx0[i] - 2 * hw_k - 1)   # (a peak at the window's end: not found)
            i = i[inner]
            d_out[i] = u[i] - (sx0[i] + ks[inner] + offs[inner] + hw_k)
            score[i] = best[inner]
    return d_out, score


def estimate(s: np.ndarray, d_axis: np.ndarray, score: np.ndarray, piece: np.ndarray, slope: np.ndarray,
             d_px: float) -> tuple[float, int, float]:
    """The texture's disparity at a feature from its patches (P,): ``s`` px from it along ``piece``, their
    axis disparity ``d_axis`` and correlation ``score``, the piece's disparity slope ``slope`` (px per px).

    Each piece with at least ``MIN_PATCHES`` confident patches (``score >= MIN_SCORE``) agreeing within
    ``2 MAX_SPREAD_PX`` once carried to the feature along the piece's slope gives their median; a piece
    turning steeply in depth (``|slope| > MAX_PIECE_SLOPE``: the two views see its bark foreshortened
    differently) gives none. The feature's estimate is the piece estimate nearest the feature's own
    disparity ``d_px`` when all lie on one side of it, ``d_px`` itself (no disagreement) when they
    straddle it.

    Returns (disparity (NaN: no verdict), confident patches used, their spread (max - min, px)).
    """
    good = np.isfinite(d_axis) & (score >= MIN_SCORE) & (np.abs(slope) <= MAX_PIECE_SLOPE)
    ests, n, spread = [], 0, 0.0
    for j in np.unique(piece[good]).tolist():
        k = good & (piece == j)
        if k.sum() < MIN_PATCHES:
            continue
        e = d_axis[k] - slope[k] * s[k]
        if np.ptp(e) > 2 * MAX_SPREAD_PX:
            continue
        ests.append(float(np.median(e)))
        n += int(k.sum())
        spread = max(spread, float(np.ptp(e)))
    if not ests:
        return float("nan"), 0, float("nan")
    diffs = np.array(ests) - d_px
    if (diffs > 0).all() or (diffs < 0).all():
        return float(ests[int(np.argmin(np.abs(diffs)))]), n, spread
    return float(d_px), n, spread
