"""Disparity of the bark surface by normalised cross-correlation along rows.

Used where the branch outline says nothing about disparity: on near-horizontal pieces a
row runs along the branch, but the bark texture still pins each point. The surface a
patch sees is nearer than the axis: 0.94 radius on the mean of its rows (+-0.6 radius,
:func:`patch_depth_fraction`), more where the branch turns in depth (the line of sight
meets the cylinder at a slant, :func:`slant_depth_factor`); :func:`surface_to_axis` moves
the disparity back onto the axis.
"""

from __future__ import annotations

import cv2
import numpy as np
from appliance.localize import kernels_points, kernels_ncc


def _flat(patch: np.ndarray, min_std: float) -> bool:
    """``patch.std() < min_std``, deciding by the patch's range where that settles it: n values
    spanning a range R have a standard deviation between R / sqrt(2 n) and R / 2."""
    lo, hi = cv2.minMaxLoc(patch)[:2]
    r = hi - lo
    if r < 2 * min_std:
        return True
    if r * r > 2.02 * patch.size * min_std * min_std:
        return False
    return bool(patch.std() < min_std)


def surface_disparity(left: np.ndarray, right: np.ndarray, uv_px: np.ndarray, half_h_px: np.ndarray,
                      d_range_px: tuple[float, float], half_w_px: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel disparity of patches centred on ``uv_px`` (rounded), and their correlation.

    Parameters
    ----------
    left, right : ndarray (H, W) uint8 or float32
        Rectified grey images.
    uv_px : ndarray (N, 2)
        Patch centres in the left image.
    half_h_px : ndarray (N,) int
        Half height of each patch (keep it inside the branch).
    d_range_px : (float, float)
        Disparities searched.

    Returns
    -------
    d, score : ndarray (N,)
        Disparity of the patch centre ``round(u)`` (NaN where the patch leaves the image)
        and its normalised correlation (-1..1).
    """
    return surface_disparity_many([(left, right, uv_px, half_h_px, d_range_px, half_w_px)])[0]


def surface_disparity_many(jobs: list) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`surface_disparity` of several searches ``(left, right, uv_px, half_h_px, d_range_px,
    half_w_px)`` (e.g. one per flat piece, each with its own images or boxes and range): the
    vectorised searches of all of them with the same patch size and number of positions run as one
    batch (each patch's scores are its own: the same values as searching it alone)."""
    out, batches = [], {}
    for job in jobs:
        d_out, score, batch = _search(*job)
        out.append((d_out, score))
        if batch is not None:
            batches.setdefault(batch[0], []).append(batch[1:])
    for (hh, hw, n_pos), entries in batches.items():
        _batch_ncc_many(entries, hh, hw, n_pos)
    return out


def _c_writable(a: np.ndarray) -> np.ndarray:
    """``np.require(a, None, ["C", "W"])``: ``a`` itself when it is a C-contiguous writable ndarray (the lazy
    reads' and the boxes' usual case, checked by its flags: ~0.1 us against np.require's ~3 us), else that copy."""
    if type(a) is np.ndarray and a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.require(a, None, ["C", "W"])


def _search(left: np.ndarray, right: np.ndarray, uv_px: np.ndarray, half_h_px: np.ndarray,
            d_range_px: tuple[float, float], half_w_px: int = 7):
    """:func:`surface_disparity` of one search, but for its vectorised part: ``(d, score, batch)``,
    ``batch`` None or ``((hh, hw, n_pos), lbox, rbox, uv, lo, hi, origin, idx, d, score)`` for
    :func:`_batch_ncc_many` to fill in."""
    h, w = left.shape
    lo, hi = int(np.floor(d_range_px[0])), int(np.ceil(d_range_px[1]))
    d_out, score = np.empty(len(uv_px)), np.empty(len(uv_px))      # (np.full's values, without its wrapper)
    d_out.fill(np.nan)
    score.fill(-1.0)
    uv_f = np.asarray(uv_px, float).reshape(-1, 2)
    hhs = np.asarray(half_h_px, int)
    if len(uv_f) == 0:
        return d_out, score, None
    hw = half_w_px
    # read each image once, over the box its patches (left) or strips (right) need (lazy images rectify it then)
    uv = None
    if hhs.shape == (len(uv_f),):       # (compiled: the same integers; None for a centre not finite)
        uv, by0, by1, lx0, lx1, rx0, rx1 = kernels_points.search_boxes(np.ascontiguousarray(uv_f),
                                                                      np.ascontiguousarray(hhs, np.int64),
                                                                      hw, lo, hi, h, w)
    if uv is None:
        uv = np.rint(uv_f).astype(int)
        by0, by1 = max(int((uv[:, 1] - hhs).min()), 0), min(int((uv[:, 1] + hhs).max()) + 1, h)
        lx0, lx1 = max(int(uv[:, 0].min()) - hw, 0), min(int(uv[:, 0].max()) + hw + 1, w)
        rx0, rx1 = max(int(uv[:, 0].min()) - hi - hw, 0), min(int(uv[:, 0].max()) - lo + hw + 1, w)
    if by1 <= by0 or lx1 <= lx0 or rx1 <= rx0:
        return d_out, score, None
    lbox, rbox = left[by0:by1, lx0:lx1], right[by0:by1, rx0:rx1]
    if lbox.dtype == np.uint8 and rbox.dtype == np.uint8:      # every patch in one compiled call (exact scores)
        kernels_ncc.ncc_search(_c_writable(lbox), _c_writable(rbox), uv,
                           np.ascontiguousarray(hhs), hw, lo, hi, h, w, by0, lx0, rx0, d_out, score)
        return d_out, score, None
    inside = (uv[:, 1] - hhs >= 0) & (uv[:, 1] + hhs + 1 <= h) & (uv[:, 0] - hw >= 0) & (uv[:, 0] + hw + 1 <= w) \
        & (uv[:, 0] - lo + hw + 1 > 0)
    # a short search (<= 33 positions), patches of one height whose strips are whole: all at once (the
    # same scores as matchTemplate's TM_CCOEFF_NORMED, in float64); the rest one by one
    whole = inside & (uv[:, 0] - hi - hw >= 0) & (uv[:, 0] - lo + hw + 1 <= w)
    batch = None
    if whole.sum() >= 2 and hi - lo <= 32:
        hh0 = int(np.bincount(hhs[whole]).argmax())
        idx = np.flatnonzero(whole & (hhs == hh0))
        if len(idx) >= 2:
            batch = ((hh0, hw, hi - lo + 1), lbox, rbox, uv[idx], lo, hi, (by0, lx0, rx0), idx, d_out, score)
            inside = inside.copy()
            inside[idx] = False
    todo = np.flatnonzero(inside)
    for i in todo.tolist():
        u, v, hh = int(uv[i, 0]), int(uv[i, 1]), int(hhs[i])
        tmpl = lbox[v - hh - by0:v + hh + 1 - by0, u - hw - lx0:u + hw + 1 - lx0]
        if _flat(tmpl, 1.0):
            continue
        xs = max(uv[i, 0] - hi - hw, 0)
        strip = rbox[v - hh - by0:v + hh + 1 - by0, xs - rx0:min(u - lo + hw + 1, w) - rx0]
        if strip.shape[1] < tmpl.shape[1] + 2:
            continue
        c = cv2.matchTemplate(strip, tmpl, cv2.TM_CCOEFF_NORMED)[0]
        k = int(c.argmax())
        off = 0.0
        if 0 < k < len(c) - 1:                          # in float32, as the scores
            denom = c[k - 1] - 2 * c[k] + c[k + 1]
            off = 0.5 * (c[k - 1] - c[k + 1]) / denom if denom < 0 else 0.0
        d_out[i] = uv[i, 0] - (xs + k + off + hw)      # numpy/Python scalar types as before (float32 or 64)
        score[i] = c[k]
    return d_out, score, batch


def _batch_ncc_many(entries: list, hh: int, hw: int, n_pos: int) -> None:
    """:func:`_batch_ncc` of several searches' patches of one size and number of positions at once:
    ``entries`` of ``(lbox, rbox, uv, lo, hi, origin, idx, d_out, score)``; the patches and strips are
    gathered from each entry's boxes, then searched together, and each entry's ``d_out[idx]``,
    ``score[idx]`` written."""
    n_h, n_w = 2 * hh + 1, 2 * hw + 1
    tm, sp = [], []
    for lbox, rbox, uv, lo, hi, (by0, lx0, rx0), _, _, _ in entries:
        y0 = uv[:, 1] - hh - by0
        tm.append(_windows(lbox, (n_h, n_w))[y0, uv[:, 0] - hw - lx0])
        sp.append(_windows(rbox, (n_h, n_pos + n_w - 1))[y0, uv[:, 0] - hi - hw - rx0])
    if len(entries) == 1:
        tmpl, strip = tm[0].astype(np.float64), sp[0].astype(np.float64)
        hi_all = entries[0][4]
    else:
        tmpl, strip = np.concatenate(tm).astype(np.float64), np.concatenate(sp).astype(np.float64)
        hi_all = np.repeat(np.array([e[4] for e in entries]), [len(e[2]) for e in entries])
    uv = entries[0][2] if len(entries) == 1 else np.concatenate([e[2] for e in entries])
    d, c_k, flat = _ncc_core(tmpl, strip, uv, hh, hw, n_pos, hi_all)
    i0 = 0
    for _, _, uv_e, _, _, _, idx, d_out, score in entries:
        sl = slice(i0, i0 + len(uv_e))
        keep = ~flat[sl]
        d_out[idx[keep]] = d[sl][keep]
        score[idx[keep]] = c_k[sl][keep]
        i0 += len(uv_e)


def _windows(box: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Every (rows, cols) window of a box, a read-only view (no copy)."""
    return np.lib.stride_tricks.as_strided(box, (box.shape[0] - size[0] + 1, box.shape[1] - size[1] + 1, *size),
                                           box.strides * 2, writeable=False)


def _ncc_core(tmpl: np.ndarray, strip: np.ndarray, uv: np.ndarray, hh: int, hw: int, n_pos: int, hi) \
        -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The vectorised search of patches ``tmpl`` (N, 2 hh + 1, 2 hw + 1) float64 along their strips
    ``strip`` (N, 2 hh + 1, n_pos + 2 hw) float64 (the same scores as matchTemplate's
    TM_CCOEFF_NORMED): each patch's disparity (its centre ``uv`` (N, 2) int; ``hi``, int or (N,), the
    largest disparity searched: its strip's first position), best score, and whether it is flat."""
    n_h, n_w = 2 * hh + 1, 2 * hw + 1
    tz = tmpl - tmpl.mean(axis=(1, 2), keepdims=True)
    t_norm = np.sqrt(np.einsum("nhw,nhw->n", tz, tz))
    flat = t_norm / np.sqrt(n_h * n_w) < 1.0                 # _flat(tmpl, 1.0): no texture
    if len(uv) * n_h <= 400:                                 # one product over a windowed view of the strips
        st = strip.strides                                   # (the same sums; faster for a few patches)
        num = np.einsum("nhw,nhkw->nk", tz, np.lib.stride_tricks.as_strided(
            strip, (len(uv), n_h, n_pos, n_w), (st[0], st[1], st[2], st[2]), writeable=False))
    else:
        num = np.empty((len(uv), n_pos))
        for k in range(n_pos):                               # (a few positions: one product each)
            num[:, k] = np.einsum("nhw,nhw->n", tz, strip[:, :, k:k + n_w])
    c1, c2 = np.zeros((2, len(uv), strip.shape[2] + 1))      # running column sums, a 0 column first
    np.cumsum(strip.sum(1), 1, out=c1[:, 1:])
    np.cumsum((strip * strip).sum(1), 1, out=c2[:, 1:])
    s1, s2 = c1[:, n_w:] - c1[:, :-n_w], c2[:, n_w:] - c2[:, :-n_w]
    var = np.maximum(s2 - s1 * s1 / (n_h * n_w), 0.0)
    den = t_norm[:, None] * np.sqrt(var)
    c = np.where(den > 1e-9, num / np.where(den > 1e-9, den, 1.0), 0.0)
    k = c.argmax(1)
    rows = np.arange(len(uv))
    km, kp = np.maximum(k - 1, 0), np.minimum(k + 1, n_pos - 1)
    denom = c[rows, km] - 2 * c[rows, k] + c[rows, kp]
    interior = (k > 0) & (k < n_pos - 1) & (denom < 0)
    off = np.where(interior, 0.5 * (c[rows, km] - c[rows, kp]) / np.where(interior, denom, -1.0), 0.0)
    d = uv[:, 0] - ((uv[:, 0] - hi - hw) + k + off + hw)
    return d, c[rows, k], flat


def surface_to_axis(d_px: np.ndarray, radius_px: float, f_px: float, offset_px: float = 0.0,
                    depth_fraction=None) -> np.ndarray:
    """Disparity of the axis ``depth_fraction`` radius behind the matched surface:
    Z_axis = Z_surface * (1 + depth_fraction * radius_px / f_px).

    ``offset_px`` is the rectified principal-point difference ``cx_left - cx_right``;
    ``depth_fraction`` (float or like ``d_px``) how far behind the matched surface the axis lies, in
    radii (:func:`patch_depth_fraction`): 1 for the surface on the centre line alone; by default that
    of the flat pieces' patches, rows +-0.6 radius (``max(1, int(0.6 radius_px))``) on a branch along
    the rows.
    """
    if depth_fraction is None:
        depth_fraction = patch_depth_fraction(radius_px, max(1, int(0.6 * radius_px)))
    return (np.asarray(d_px, float) - offset_px) / (1.0 + depth_fraction * radius_px / f_px) + offset_px


def axis_to_surface(d_px, radius_px: float, f_px: float, offset_px: float, depth_fraction):
    """:func:`surface_to_axis` inverted: the disparity (px, scalar or array, its type kept) of the surface
    ``depth_fraction`` radius in front of an axis at ``d_px`` (where a texture patch centred on the axis matches)."""
    return (d_px - offset_px) * (1.0 + depth_fraction * radius_px / f_px) + offset_px


def patch_depth_fraction(radius_px: float, half_h_px: int, slope=0.0):
    """Mean depth of a cylinder's visible surface over a patch's rows, in radii in front of the axis.

    A patch of rows ``-half_h_px .. half_h_px`` centred on a (near-horizontal) branch's centre line
    straddles the cylinder: a row ``y`` px off the centre line, ``y cos(a)`` from the axis across the
    branch (``a`` its angle to the rows, ``slope = tan(a)``), sees the surface ``sqrt(r^2 - (y cos a)^2)``
    in front of the axis, less than one radius ``r``. The correlation's peak is the rows' mean shift
    (each row weighs alike), so the matched depth is that of the mean of those offsets: 0.94 radii
    for rows of +-0.6 radius (the surface-to-axis step by a whole radius put the axis 0.06 radii too far
    away: a disparity 0.1-0.25 px low on branches of 8-20 px radius).

    Parameters
    ----------
    radius_px : float
        Branch radius in the image.
    half_h_px : int
        The patch's half height (rows).
    slope : float or ndarray (N,)
        The centre line's dv/du at each patch.

    Returns
    -------
    float or ndarray (N,)
        The fraction of a radius (0..1) to move back from the matched surface to the axis.
    """
    y = np.arange(-half_h_px, half_h_px + 1, dtype=float)
    cos_a = 1.0 / np.sqrt(1.0 + np.square(np.asarray(slope, float)))
    t = np.multiply.outer(cos_a, y) / max(radius_px, 1e-9)
    return np.sqrt(np.clip(1.0 - t * t, 0.0, None)).mean(axis=-1)


def slant_depth_factor(u_px: np.ndarray, v_px: np.ndarray, d_px: np.ndarray, dd_du, dv_du: np.ndarray,
                       f_px: float, centre_px: tuple[float, float], offset_px: float = 0.0) -> np.ndarray:
    """How much deeper than one radius the axis lies behind the surface along the line of sight.

    The line of sight through an axis point meets the cylinder ``r / sin(theta)`` before the
    axis (``theta`` its angle to the axis): for a branch turning in depth along the rows (axis at
    ``beta`` to the image plane, seen along the optical axis) the axis lies ``r / cos(beta)`` behind
    the surface, not ``r`` (1.08 r at a disparity slope of 0.05 px/px at 1000 mm, 1.6 r at 0.15).
    The depth difference is that distance times the line of sight's cosine to the optical axis
    (which cancels the obliquity of a fronto-parallel branch off the image's centre).

    Parameters
    ----------
    u_px, v_px, d_px : ndarray (N,)
        Axis points in the rectified left view, and their disparity.
    dd_du : float or ndarray (N,)
        The axis' disparity slope along the rows (px per px).
    dv_du : ndarray (N,)
        Its centre line's slope.
    f_px : float
        Rectified focal length.
    centre_px : (float, float)
        Principal point (cx, cy) of the rectified left view (the image's middle does: a small share).
    offset_px : float
        ``cx_left - cx_right``.

    Returns
    -------
    ndarray (N,)
        The factor (>= about 1) multiplying the radius moved back along the line of sight.
    """
    u, v = np.asarray(u_px, float), np.asarray(v_px, float)
    dz = np.maximum(np.asarray(d_px, float) - offset_px, 1e-6)
    ray = np.stack([(u - centre_px[0]) / f_px, (v - centre_px[1]) / f_px, np.ones_like(u)])   # point / Z
    z = 1.0 / dz                                                     # depth in units of f * baseline
    dz_du = -dd_du * z / dz
    axis = ray * dz_du + np.stack([z / f_px, z * np.asarray(dv_du, float) / f_px, np.zeros_like(u)])
    ray_n = ray / np.linalg.norm(ray, axis=0)
    cos_t = np.abs((ray_n * axis).sum(0)) / np.maximum(np.linalg.norm(axis, axis=0), 1e-12)
    return ray_n[2] / np.sqrt(np.maximum(1.0 - cos_t * cos_t, 1e-6))


def nearer_in_front(left: np.ndarray, right: np.ndarray, uv_px: np.ndarray, d_branch_px: np.ndarray,
                    half_px: np.ndarray, d_max_px: float, margin_px: float = -3.0, min_score: float = 0.7,
                    min_lead: float = 0.1) -> np.ndarray:
    """True where the patch at ``uv_px`` is not behind the branch (its disparity larger than
    ``d_branch_px + margin_px``; the default margin takes things at the branch's own depth too).

    Tells a branch end hidden by a leaf or an apple (the patch just beyond it is that
    occluder, at the branch's depth or in front) from a true tip (beyond it lies the
    background, far behind). The search spans disparities from 1 px (far background) to
    ``d_max_px``; the patch counts as in front only if its best match in front scores
    >= ``min_score`` and beats every match behind by ``min_lead``. Patches without
    texture count as not in front.
    """
    uv = np.asarray(uv_px, float).reshape(-1, 2)
    out = np.zeros(len(uv), bool)
    h, w = left.shape
    for i, (u, v) in enumerate(np.rint(uv).astype(int)):
        hh = int(half_px[i])
        if v - hh < 0 or v + hh + 1 > h or u - hh < 0 or u + hh + 1 > w:
            continue
        x0 = max(int(u - np.ceil(d_max_px)) - hh, 0)
        if not u - (x0 + hh) > d_branch_px[i] + margin_px:
            continue                        # no position in front (the strip's first is the nearest): read nothing
        tmpl = left[v - hh:v + hh + 1, u - hh:u + hh + 1]
        if _flat(tmpl, 2.0):
            continue
        strip = right[v - hh:v + hh + 1, x0:u - 1 + hh + 1]
        if strip.shape[1] <= tmpl.shape[1]:
            continue
        if strip.dtype == np.uint8 and tmpl.dtype == np.uint8:      # (exact scores: kernels_ncc.ncc_scores)
            c = kernels_ncc.ncc_scores(np.require(strip, None, ["C", "W"]), np.require(tmpl, None, ["C", "W"]))
        else:
            c = cv2.matchTemplate(strip, tmpl, cv2.TM_CCOEFF_NORMED)[0]
        d = u - (x0 + np.arange(len(c)) + hh)          # disparity of each position
        front = d > d_branch_px[i] + margin_px
        behind = ~front
        if not front.any():
            continue
        best_front = c[front].max()
        best_behind = c[behind].max() if behind.any() else -1.0
        out[i] = bool(best_front >= min_score and best_front >= best_behind + min_lead)
    return out
