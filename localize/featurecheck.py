"""An independent check of each matched feature's disparity by the bark texture of its own branches.

The matcher places a tip or a fork from the branch outlines (and, on flat pieces, their texture) by
several mechanisms; each has its own ways to fail, and a feature grossly off in depth (seeds 260-291:
1-4 px of disparity, 6-18 mm) is worse for the arm than a feature not reported. This check knows none
of those mechanisms. Near each feature it takes small patches of the left grey image inside the
feature's branch(es) (a tip: along its branch from ``TIP_BACK`` radius back; a fork: along each of its
pieces, clear of the other pieces' silhouettes), finds each patch's disparity in the right image along
the same rectified row by normalised cross-correlation (:func:`kernels_ncc.ncc_peaks`: exact integer sums,
sub-pixel parabola; a patch without a confident peak near the feature's disparity searched again over the
whole working range, its peak counting only when unique: :func:`patch_disparities`), moves it from the bark surface back onto the axis (:func:`texture.surface_to_axis`)
and carries it to the feature along the branch (:func:`estimate`: the least alarming of the texture's
and the matched piece's slopes). Where that differs from the feature's disparity by more than
``max_diff_px`` the feature is withheld; so is a fork two of whose pieces' own texture estimates lie
beyond ``AGREE_PX`` on one side of its disparity with none beyond ``OPPOSE_PX`` on the other (the
pieces' agreement: :func:`estimate`), and a feature one of whose pieces' own patches read more than
``FAR_PX`` from it (:func:`far_piece`: a piece not at the fork's depth, whatever the others read). Patches without texture, off the branch or matched weakly,
and pieces turning steeply in depth give no verdict: the feature is kept.
Measured on 60 scenes and seeds 260-387: docs/localize-featurecheck.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from appliance.localize import kernels_check, kernels_ncc
from appliance.localize.texture import surface_to_axis

TIP_BACK = 1.0               # a tip's patches start this many radii back along its branch
FORK_CLEAR = 1.2             # a fork's this many x its other pieces' largest radius out (clear of them)
REACH_RADII = 3.0            # ... and span this many radii of the piece
MIN_SPAN_PX, MAX_SPAN_PX = 20.0, 40.0    # ... but at least / at most this many px
STEP_RADII = 0.75            # one patch every this many radii
MIN_STEP_PX, MAX_STEP_PX = 3.0, 8.0
MIN_REACH_PX = 4.0           # patches start at least this far from the feature
FLAT_SIN, STEEP_SIN = 0.5, 0.87   # a patch inside a branch under 30 deg to the rows: long along the rows (half
                                  # height 0.6 r, half width 7 px); over 60 deg: narrow across (half height 4 px,
                                  # half width 0.6 r); a square of half side 0.45 r otherwise (kernels_check)
WINDOW_PX = 8                # each patch searched within +-this of the feature's disparity ...
MAX_SLOPE = 0.1              # ... widened by this many px per px from the feature
MIN_SCORE = 0.7              # a patch matched with a lower correlation gives no verdict
NEAR_PX = 2.0                # no confident peak in the window: the whole working range searched; its peak counts
WIDE_RATIO = 2.0             # ... when 1 - its score is this many times under 1 - the best score within +-NEAR_PX
WIDE_AWAY_PX = 3.0           # of the piece's disparity and 1 - every other local maximum further than this from it
                             # (smooth bark correlates 0.9+ along a row: the dissimilarities tell peaks apart)
MIN_MISS = 0.005             # (1 - the peak's score taken as at least this: two perfect peaks are not unique)
MIN_STD = 2.0                # a patch with a lower grey-level standard deviation has no texture
MIN_PATCHES = 2              # a piece with fewer confident patches gives no verdict
MAX_PIECE_SLOPE = 0.12       # a piece whose disparity changes faster (px per px) gives no verdict
MAX_SPREAD_PX = 0.5          # patches carried along the piece's slope agreeing within twice this (px): an estimate
FIT_MIN_PATCHES = 3          # the texture's own line: at least this many patches ...
FIT_MIN_SPAN_PX = 10.0       # ... spanning this many px ...
FIT_MAX_RES_PX = 0.3         # ... none off it by more than this
AGREE_PX = 0.9               # a feature two of whose pieces' own texture estimates lie beyond this on one side ...
OPPOSE_PX = 0.3              # ... and none beyond this on the other is withheld (issue 5, seeds 356-387's forks)
FAR_PX = 3.0                 # a feature one of whose pieces' own texture reads further off is withheld ...
FAR_MIN_PATCHES = 3          # ... by at least this many confident patches ...
FAR_SPREAD_PX = 1.0          # ... carried along its slope within this of each other (seed 534 T11: 13 px)
TURN_SLOPE = 0.05            # a tip whose piece turns in depth at least this fast (px of disparity per px) ...
TURN_PX = 0.7                # ... and whose texture reads it more than this short of its own disparity, on the
                             # side the piece comes from (its end carried too far along the turn), is withheld
                             # (:func:`turn_overshoot`; seed 516 T17: 0.9 px, -6.6 mm) ...
TURN_CARRY_SHARE = 0.6       # ... and more than this share of the disparity its patches were carried across to the
                             # tip (|slope| x their mean distance: the carry's own uncertainty; right tips: seed 548
                             # T15 0.76 px after a 2.1 px carry, 385 T8 0.84 after 1.6; 516 T17 0.76 after 1.14)


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
        The texture's disparity carried to the feature (:func:`estimate`; NaN: no verdict); where a
        piece reads it more than ``FAR_PX`` off (:func:`far_piece`), that piece's.
    n_patches : int
        Confident patches of the pieces that gave an estimate.
    spread_px : float
        The largest spread (max - min, px) of a piece's patches carried along its slope.
    withheld : bool
        ``|d_check_px - d_px| > max_diff_px`` (incl. a far piece) or ``|agree_px| > agree_px``
        (:func:`check_features`).
    agree_px : float
        The pieces' agreement (:func:`estimate`: the second largest of the pieces' own texture estimates
        minus the feature's disparity when none reads under -``OPPOSE_PX``, or the mirror; 0: they do not
        agree; NaN: fewer than two pieces give one), px.
    overshoot_px : float
        A tip on a piece turning in depth: how far its disparity lies past the texture's along the turn
        (:func:`turn_overshoot`; NaN: not such a tip, or no verdict), px.
    turned : bool
        Withheld for that overshoot (beyond ``TURN_PX`` and ``TURN_CARRY_SHARE`` of the texture's carry).
    """

    node: int
    d_px: float
    d_check_px: float
    n_patches: int
    spread_px: float
    withheld: bool
    agree_px: float = math.nan
    overshoot_px: float = math.nan
    turned: bool = False

    @property
    def diff_px(self) -> float:
        """Texture minus feature disparity (NaN: no verdict)."""
        return self.d_check_px - self.d_px


def check_features(features: list, pieces: list, left, right, left_mask: np.ndarray,
                   d_range_px: tuple[float, float], f_px: float, offset_px: float = 0.0,
                   max_diff_px: float = 1.6, agree_px: float | None = None) -> list[FeatureCheck]:
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
        Left branch coverage 0-255; a patch must lie where it is >= 128 (corners, edge midpoints, centre).
    d_range_px : (float, float)
        Disparities of the working range (patches are searched within them).
    f_px, offset_px : float
        Rectified focal length and ``cx_left - cx_right``.
    max_diff_px : float
        A feature whose texture disparity differs by more is withheld.
    agree_px : float, optional
        A feature whose pieces agree (:func:`estimate`'s ``agree``) beyond this is withheld too (None:
        ``AGREE_PX``, read at the call; inf: never).

    Returns
    -------
    list of FeatureCheck
        One per feature, in order.
    """
    t = patch_table(features, pieces, left, right, left_mask, d_range_px, f_px, offset_px)
    d_px = np.array([ft.d for ft in features], float)
    d_check, n, spread, agree = estimate(t, d_px)
    far = far_piece(t, d_px)
    d_check = np.where(np.abs(far) > FAR_PX, d_px + far, d_check)     # (a far piece's reading: "texture")
    limit = AGREE_PX if agree_px is None else agree_px
    over, carry = turn_overshoot(t, d_px, d_check, np.array([ft.kind == "endpoint" for ft in features], bool))
    turned = over > np.maximum(TURN_PX, TURN_CARRY_SHARE * carry)                                  # (NaN: False)
    withheld = (np.abs(d_check - d_px) > max_diff_px) | (np.abs(agree) > limit) | turned
    return [FeatureCheck(int(ft.node), float(d_px[i]), float(d_check[i]), int(n[i]), float(spread[i]),
                         bool(withheld[i]), float(agree[i]), float(over[i]), bool(turned[i]))
            for i, ft in enumerate(features)]


def turn_overshoot(t: dict, d_px: np.ndarray, d_check: np.ndarray, tip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How far each tip on a piece turning in depth lies past its texture's reading along the turn, and the
    disparity its texture was carried across, px (F,) each.

    ``t``: :func:`patch_table`'s (``feature``, ``s``: px from the feature, ``slope``: the piece's disparity
    slope away from the feature, px per px, ``d_axis``, ``score``); ``d_px``, ``d_check`` (F,): the features'
    disparities and the texture's estimate (:func:`estimate`; NaN: no verdict); ``tip`` (F,): the features
    that are tips. For a tip whose piece's ``|slope| >= TURN_SLOPE``: the overshoot ``(d_check - d) *
    sign(slope)``, positive where the tip's disparity lies beyond the texture's on the far side from the
    piece's body (its end extrapolated too far along the turn), and the carry ``|slope|`` x the mean ``s`` of
    its confident patches (``score >= MIN_SCORE``, at least ``FIT_MIN_PATCHES``: two cannot tell their own line; seed 467 T4, right, read 1.5 px off by two); NaN for every other feature. A tip's end on such a piece
    is read from the last few px of a curve bending in depth (seed 516 T17: 165.7, 166.4, 167.5 px over its
    last 13 px, 1.05 px past the truth; its three patches 7-18 px back read it within 0.15 px): the check's
    ``max_diff_px`` (1.6, set by the noise of every feature) lets such an overshoot pass. The texture's
    reading is itself carried along the slope: ``check_features`` withholds an overshoot beyond ``TURN_PX``
    and beyond ``TURN_CARRY_SHARE`` of the carry."""
    nf = len(d_px)
    over, carry = np.full(nf, np.nan), np.full(nf, np.nan)
    if len(t["feature"]) == 0:
        return over, carry
    f, first = np.unique(t["feature"], return_index=True)          # (a tip has one piece: its slope)
    slope = np.full(nf, np.nan)
    slope[f] = t["slope"][first]
    ok = np.isfinite(t["d_axis"]) & (t["score"] >= MIN_SCORE)
    n_ok = np.bincount(t["feature"][ok], minlength=nf)
    s_mean = np.bincount(t["feature"][ok], weights=t["s"][ok], minlength=nf) / np.maximum(n_ok, 1)
    turns = tip & (np.abs(np.nan_to_num(slope)) >= TURN_SLOPE) & np.isfinite(d_check) & (n_ok >= FIT_MIN_PATCHES)
    over[turns] = ((d_check - d_px) * np.sign(slope))[turns]
    carry[turns] = (np.abs(slope) * s_mean)[turns]
    return over, carry


def far_piece(t: dict, d_px: np.ndarray) -> np.ndarray:
    """Each feature's piece reading furthest from its disparity: the median of a piece's confident patches
    (``score >= MIN_SCORE``) carried to the feature along the piece's slope, where there are at least
    ``FAR_MIN_PATCHES`` and all lie within ``FAR_SPREAD_PX`` (max - min) of each other, minus the feature's
    disparity ``d_px`` (F,); the one largest in magnitude per feature, px (F,). Only pieces some of whose
    patches lie beyond ``FAR_PX`` are read (0: no piece can read beyond it).

    :func:`estimate` takes the least alarming reading: pieces on both sides of a fork's disparity are
    its agreement. A piece whose own bark reads several px away is not at the fork's depth in space,
    whatever the others read: a branch behind another seen leaving it at its outline (an occlusion taken
    for a fork, seed 534 T11: the child's four patches at 163.0 +- 0.1 px, the fork and its parent at
    176.3, 81 mm off), or a fork placed on the wrong branch. ``check_features`` withholds a feature
    whose far piece is beyond ``FAR_PX`` (the texture's noise at a fork is ~1 px)."""
    nf = len(d_px)
    far = np.zeros(nf)
    ok = np.isfinite(t["d_axis"]) & (t["score"] >= MIN_SCORE)
    if not ok.any():
        return far
    f, p = t["feature"][ok], t["piece"][ok]
    e = t["d_axis"][ok] - t["slope"][ok] * t["s"][ok]             # (carried to the feature)
    key = f.astype(np.int64) * (int(p.max()) + 1) + p
    order = np.argsort(key, kind="stable")
    key, e, f = key[order], e[order], f[order]
    gs = np.concatenate(([0], np.flatnonzero(np.diff(key)) + 1))      # (np.r_'s arrays, without its parsing)
    ge = np.concatenate((gs[1:], [len(key)]))
    hi, lo, d = np.maximum.reduceat(e, gs), np.minimum.reduceat(e, gs), d_px[f[gs]]
    # (only pieces whose patches reach beyond FAR_PX can read beyond it: the rest are not read)
    read = (ge - gs >= FAR_MIN_PATCHES) & (hi - lo <= FAR_SPREAD_PX) & ((hi - d > FAR_PX) | (d - lo > FAR_PX))
    for a, b in zip(gs[read].tolist(), ge[read].tolist()):
        x = float(np.median(e[a:b])) - float(d_px[f[a]])
        if abs(x) > abs(far[f[a]]):
            far[f[a]] = x
    return far


def patch_table(features: list, pieces: list, left, right, left_mask: np.ndarray, d_range_px, f_px: float,
                offset_px: float) -> dict:
    """Every feature's patches and their texture disparity: the arrays (P,) of :func:`_patches` (``feature``,
    ``piece``, ``s`` px from the feature along the piece, ``u``, ``v``, ...) and ``score`` (the correlation)
    and ``d_axis`` (the patch's texture disparity moved onto the axis; NaN: none)."""
    t = _patches(features, pieces, left_mask)
    w = left_mask.shape[1]
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


def _pairs(fa: np.ndarray, pieces: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every feature and (not recovered) piece ending at its node: feature index (K,), piece index (K,)
    (by feature, then piece), and the largest radius of the feature's other pieces (K,) px (the feature's own
    radius where it has no other). ``fa`` (F, 6): each feature's node, u, v, d, radius px, fork (1/0)."""
    pa = np.array([(p.nodes[0], p.nodes[1], p.radius_px, not p.recovered and len(p.uvd) >= 2
                    and math.isfinite(p.radius_px)) for p in pieces], float).reshape(-1, 4)
    match = ((fa[:, :1] == pa[None, :, 0]) | (fa[:, :1] == pa[None, :, 1])) & (pa[None, :, 3] > 0)
    fi, pj = np.nonzero(match)
    if len(fi) == 0:
        return fi, pj, np.zeros(0)
    radius = np.where(match, pa[None, :, 2], -np.inf)                 # (F, P)
    top = radius.argmax(1)
    first = radius[np.arange(len(fa)), top]
    radius[np.arange(len(fa)), top] = -np.inf
    second = radius.max(1)
    r_other = np.where(pj == top[fi], second[fi], first[fi])
    return fi, pj, np.where(np.isfinite(r_other), r_other, fa[fi, 4])


def _patches(features: list, pieces: list, left_mask: np.ndarray) -> dict:
    """Every feature's patches along its pieces, all at once: a dict of arrays (P,) ``feature``, ``piece``,
    ``s`` (px from the feature along the piece), ``u``, ``v`` (int centre), ``d_ref`` (the disparity searched
    around: the feature's), ``hh``, ``hw`` (int half height, width), ``across`` (half extent across the axis,
    px), ``r`` (the piece's radius px), ``slope`` (the piece's disparity slope over the patches' reach, px per
    px, away from the feature). A fork's patches start clear of its other pieces' silhouettes
    (``FORK_CLEAR`` x their largest radius), a tip's ``TIP_BACK`` radius back; patches inside the image and
    the left mask only; pieces turning steeply in depth (``|slope| > MAX_PIECE_SLOPE``) or too short give none."""
    fa = np.array([(ft.node, ft.u, ft.v, ft.d, ft.radius_px, ft.kind == "bifurcation") for ft in features],
                  float).reshape(-1, 6)
    fi, pj, r_other = _pairs(fa, pieces)
    cols = ("feature", "piece", "s", "u", "v", "d_ref", "hh", "hw", "across", "r", "slope")
    if len(fi) == 0:
        return {c: np.zeros(0, np.int64 if c in ("feature", "piece", "u", "v", "hh", "hw") else float) for c in cols}
    used = np.unique(pj)
    uvd = np.concatenate([pieces[j].uvd for j in used.tolist()]).astype(float)     # (the used pieces end to end)
    starts = np.concatenate(([0], np.cumsum([len(pieces[j].uvd) for j in used.tolist()]))).astype(np.int64)
    r = np.maximum(np.array([pieces[j].radius_px for j in pj.tolist()], float), 1.0)
    s0 = np.maximum(np.where(fa[fi, 5] > 0, FORK_CLEAR * r_other, TIP_BACK * r), MIN_REACH_PX)
    reach = np.clip(REACH_RADII * r, MIN_SPAN_PX, MAX_SPAN_PX)
    dstep = np.clip(STEP_RADII * r, MIN_STEP_PX, MAX_STEP_PX)
    # the piece's slope: least squares over 9 points of [s0 - r, max(s1, s0 + MIN_SPAN_PX)] (s1 = s0 + reach,
    # both within the piece); the patches at s0, s0 + step, ... up to s1 (their direction: 1 px either side)
    consts = np.array([MIN_SPAN_PX, MAX_PIECE_SLOPE, FLAT_SIN, STEEP_SIN])
    pair, _, u, v, hh, hw, across, s, slope = kernels_check.place_patches(
        uvd, starts, np.searchsorted(used, pj), np.ascontiguousarray(fa[fi, 1:3]), r, s0, reach, dstep, left_mask,
        int(MAX_SPAN_PX // MIN_STEP_PX) + 1, consts)
    d_feat = fa[fi, 3]
    return {"feature": fi[pair], "piece": pj[pair], "s": s, "u": u, "v": v, "d_ref": d_feat[pair], "hh": hh,
            "hw": hw, "across": across, "r": r[pair], "slope": slope[pair]}


def patch_disparities(left, right, t: dict, d_range_px: tuple[float, float], w: int) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel disparity (P,) of the bark surface of each patch of the table ``t`` (:func:`patch_table`'s
    columns ``feature``, ``u``, ``v``, ``d_ref``, ``hh``, ``hw``, ``s``, ``slope``; rows grouped by feature;
    NaN: no texture, or no confident peak) and its correlation (P,).

    Each patch is searched within ``d_ref`` +- (``WINDOW_PX`` + ``MAX_SLOPE`` x ``s``) (and the working
    range). A textured patch whose window holds no confident peak (its best at the window's end, or
    scoring under ``MIN_SCORE``) is searched again over the whole working range: a peak there counts when
    it scores ``>= MIN_SCORE``, is not at the range's end, and its dissimilarity (1 - score, at least
    ``MIN_MISS``) is under
    1 / ``WIDE_RATIO`` of that of the best within +-``NEAR_PX`` of the piece's own disparity at the patch
    (``d_ref + slope s``) and of every other local maximum over ``WIDE_AWAY_PX`` from it
    (:func:`kernels_check.wide_peaks`)."""
    n = len(t["u"])
    d_out, score = np.full(n, np.nan), np.full(n, -1.0)
    if n == 0:
        return d_out, score
    u, hw = t["u"], t["hw"]
    half = WINDOW_PX + MAX_SLOPE * t["s"]
    lo = np.maximum(np.floor(t["d_ref"] - half), math.floor(d_range_px[0])).astype(np.int64)
    hi = np.minimum(np.ceil(t["d_ref"] + half), math.ceil(d_range_px[1])).astype(np.int64)
    sx0, sx1 = np.maximum(u - hi - hw, 0), np.minimum(u - lo + hw + 1, w)
    ok, ks, offs, sc = _search(left, right, t, np.arange(n), sx0, sx1, kernels_ncc.ncc_peaks, (), (MIN_STD,))
    found = ok & (ks > 0) & (ks < sx1 - sx0 - 2 * hw - 1)           # (a peak at the window's end: not found)
    d_out[found] = (u - (sx0 + ks + offs + hw))[found]
    score[found] = sc[found]
    wide = np.flatnonzero(ok & ~(found & (sc >= MIN_SCORE)))       # (textured, no confident peak in the window)
    if len(wide):
        uw, hww = u[wide], hw[wide]
        wx0 = np.maximum(uw - math.ceil(d_range_px[1]) - hww, 0)
        wx1 = np.minimum(uw - math.floor(d_range_px[0]) + hww + 1, w)
        d_near = t["d_ref"][wide] + t["slope"][wide] * t["s"][wide]
        n0 = np.floor(uw - hww - wx0 - d_near - NEAR_PX).astype(np.int64)      # (strip positions of d_near +- NEAR_PX)
        n1 = np.ceil(uw - hww - wx0 - d_near + NEAR_PX).astype(np.int64)
        okw, kw, ow, best, near, second = _search(left, right, t, wide, wx0, wx1, kernels_check.wide_peaks, (n0, n1),
                                                  (int(WIDE_AWAY_PX), MIN_STD))
        miss = np.maximum(1.0 - best, MIN_MISS)
        take = okw & (best >= MIN_SCORE) & (1.0 - near >= WIDE_RATIO * miss) & (1.0 - second >= WIDE_RATIO * miss)
        d_out[wide[take]] = (uw - (wx0 + kw + ow + hww))[take]
        score[wide[take]] = best[take]
        d_out[wide[~take]], score[wide[~take]] = np.nan, -1.0
    return d_out, score


def _search(left, right, t: dict, rows: np.ndarray, sx0: np.ndarray, sx1: np.ndarray, kernel, per: tuple,
            tail: tuple) -> tuple:
    """``kernel(lbox, rbox, ty, tx, hh, hw, sx0, sx1, *per, *tail)`` (:func:`kernels_ncc.ncc_peaks` or
    :func:`kernels_check.wide_peaks`) of the patches ``rows`` (K,) of the table ``t`` (grouped by feature)
    along the right-image columns ``sx0[k]:sx1[k]`` of each, one call per feature and patch width, each
    feature's patches read in one box of each image. ``per``: arrays (K,) passed per patch; ``tail``:
    scalars. Returns the kernel's arrays (K,) in the order of ``rows``."""
    u, v, hh, hw, f = (t[c][rows] for c in ("u", "v", "hh", "hw", "feature"))
    n = len(rows)
    fs = np.concatenate(([0], np.flatnonzero(np.diff(f)) + 1))        # (np.r_'s arrays, without its parsing)
    boxes = np.column_stack([np.minimum.reduceat(v - hh, fs), np.maximum.reduceat(v + hh, fs) + 1,
                             np.minimum.reduceat(u - hw, fs), np.maximum.reduceat(u + hw, fs) + 1,
                             np.minimum.reduceat(sx0, fs), np.maximum.reduceat(sx1, fs)])
    order = np.lexsort((hw, f))                                      # (by feature, then patch width)
    key = f[order] * 64 + hw[order]
    gs = np.concatenate(([0], np.flatnonzero(np.diff(key)) + 1))
    ge = np.concatenate((gs[1:], [n]))
    box_of = np.searchsorted(fs, order[gs], side="right") - 1       # each group's feature's box
    out = None
    last = -1
    for a, b, kb in zip(gs.tolist(), ge.tolist(), box_of.tolist()):
        y0, y1, lx0, lx1, rx0, rx1 = boxes[kb].tolist()
        if kb != last:
            lbox = np.ascontiguousarray(left[y0:y1, lx0:lx1])
            rbox = np.ascontiguousarray(right[y0:y1, rx0:rx1])
            last = kb
        i = order[a:b]
        res = kernel(lbox, rbox, v[i] - y0, u[i] - lx0, hh[i], int(hw[i[0]]), sx0[i] - rx0, sx1[i] - rx0,
                     *(p[i] for p in per), *tail)
        if out is None:
            out = [np.zeros(n, r.dtype) for r in res]
        for o, r in zip(out, res):
            o[i] = r
    return tuple(out)


def estimate(t: dict, d_px: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The texture's disparity at each feature from the patch table ``t`` (:func:`patch_table`; rows grouped
    by feature, then piece) and the features' disparities ``d_px`` (F,).

    A piece's confident patches (``score >= MIN_SCORE``, at least ``MIN_PATCHES``) are carried to the feature
    along a slope. Where they lie on a straight line of their own (at least ``FIT_MIN_PATCHES`` spanning
    ``FIT_MIN_SPAN_PX``, none off it by more than ``FIT_MAX_RES_PX``, its slope within ``MAX_PIECE_SLOPE``)
    the slope is the texture's or the matched piece's: the two lines through the patches' centroid bound
    the piece's estimate at the feature, and the bound nearer the feature's disparity counts (none when
    the feature's lies between them). Otherwise they are carried along the piece's slope and their mean
    counts when they agree within ``2 MAX_SPREAD_PX``. The feature's estimate is the piece estimate
    nearest its disparity when all lie on one side of it, its own disparity (agreement) when they
    straddle it: the least alarming reading of the texture.

    The pieces' agreement: each piece's own texture estimate at the feature (its line's value where it
    fits one, else its patches carried along its slope, as above; not the least alarming bound); where two
    or more pieces give one, the second largest minus the feature's disparity when none lies under
    -``OPPOSE_PX``, the second smallest when none lies over ``OPPOSE_PX`` (0 otherwise). Two pieces (a
    parent and a child) both reading ~1 px off on the same side: each alone is within the texture's
    noise at a fork (patches 30-80 px out), together they are not (issue 5, seeds 356-387).

    Returns
    -------
    d_check, n, spread, agree : ndarray (F,)
        The estimate (NaN: no verdict), the confident patches of the pieces that gave one (int), the
        largest spread (max - min, px) of their values carried along the pieces' slopes, and the pieces'
        agreement (px; NaN: fewer than two pieces with an estimate).
    """
    nf = len(d_px)
    d_check, n_used, spread = np.full(nf, np.nan), np.zeros(nf, np.int64), np.full(nf, np.nan)
    agree = np.full(nf, np.nan)
    consts = np.array([MIN_SCORE, MIN_PATCHES, MAX_SPREAD_PX, FIT_MIN_PATCHES, FIT_MIN_SPAN_PX, FIT_MAX_RES_PX,
                       MAX_PIECE_SLOPE, OPPOSE_PX], float)
    kernels_check.estimate_pieces(t["feature"], t["piece"], t["s"], t["d_axis"], t["slope"], t["score"],
                                  np.asarray(d_px, float), consts, d_check, n_used, spread, agree)
    return d_check, n_used, spread, agree
