"""Sub-pixel outline of branches along rows from the grey image.

A binary branch mask (exact or from a segmenter) places each outline only to a pixel; remapped
into the rectified frame with linear interpolation its half-coverage crossing is good to some
0.3-0.5 px per row. The grey image's outline is anti-aliased (optics blur, sensor area): the
intensity step along the row locates it to a small fraction of a pixel. :func:`refine_runs`
moves run boundaries to the strongest step within 1.5 px of the mask's where the step is clear,
and all of them by the mask's bias (docs/localize-subpixel.md has the figures).
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
from appliance.localize import kernels_match, kernels_refine
from appliance.localize.curves import median
from appliance.localize.edges import Runs

_REMAP_WIDTH = 1024      # the queried pixels go to cv2.remap as rows of this width
WHOLE_PIXEL_SHARE = 0.5  # boundaries on the original's pixel boundaries: a binary mask (the grey step alone)
STEEP_TAN = 1.0          # outlines within 45 deg of vertical are refined along the row
GREY_SD_PX = 0.10        # the grey step's error (sd, px) against the truth's outline (steep boundaries it moves)
_NO_ONLY, _NO_MASK, _NO_MAP = np.zeros(0, bool), np.zeros((3, 3), np.uint8), np.zeros((2, 2), np.float32)


def gather(gray, row: np.ndarray, col: np.ndarray) -> np.ndarray:
    """``gray[row, col]`` of an ndarray or of a :class:`~appliance.localize.rectify.LazyRectified`.

    A lazily rectified image is not remapped by tiles: just the queried pixels are, through the
    same remap tables (a BGR source is remapped, then converted to grey: the same values but for
    rounding), a small fraction of the tiles' cost.

    Parameters
    ----------
    gray : ndarray (H, W) or LazyRectified
    row : ndarray (K,) int
    col : ndarray (K, n) int
        Columns per row (clipped to the image).

    Returns
    -------
    ndarray (K, n) float32
    """
    h, w = gray.shape
    if isinstance(gray, np.ndarray):
        col = np.minimum(np.maximum(col, 0), w - 1)         # (np.clip's values, without its overhead)
        return gray[row[:, None], col].astype(np.float32)
    m1, m2 = gray.rectifier.maps[gray.side]
    n = col.size
    # the queried pixels' map entries as rows of _REMAP_WIDTH (remap's output stays < 32767 rows), padded
    # with entry 0 (compiled: kernels_refine.remap_tables, the same entries)
    map1, map2 = kernels_refine.remap_tables(m1.view(np.int32).reshape(-1), m2.reshape(-1),
                                             np.ascontiguousarray(row, np.int64), np.ascontiguousarray(col, np.int64),
                                             int(w), _REMAP_WIDTH)
    out = cv2.remap(gray.image, map1.view(np.int16).reshape(map1.shape + (2,)), map2, cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    if out.ndim == 3:
        out = cv2.cvtColor(out, cv2.COLOR_BGR2GRAY)
    return out.reshape(-1)[:n].reshape(col.shape).astype(np.float32)


# numpy's float32 log of max(v, 1e-3) for whole grey steps v = 0..255 (refine_boundaries' logs, by look-up)
_LOG_STEPS = np.log(np.maximum(np.arange(256, dtype=np.float32), 1e-3))
_LOG_STEPS.flags.writeable = False


def refine_boundaries(gray, row: np.ndarray, x_px: np.ndarray, min_step: float = 12.0, min_share: float = 0.25,
                      max_shift_px: float = 1.5) -> np.ndarray:
    """Boundaries moved to the grey image's intensity step along their row.

    The step is the peak of the difference of neighbouring pixels, signed like the difference of
    the plateaus either side (the mean of the two pixels at each end of a 7 px window centred on
    the boundary's pixel), among the differences within 1.5 px of the mask's boundary; a Gaussian
    through the peak and its neighbours places it to a few hundredths of a pixel on a blurred step
    (a parabola, used where a neighbour is <= 0, is off by up to 0.2 px). It counts only where
    clear: at least ``min_step`` grey levels and ``min_share`` of the plateaus' difference, a true
    peak (above its neighbours), and within ``max_shift_px`` of the mask's boundary.

    Parameters
    ----------
    gray : ndarray (H, W) uint8 or LazyRectified
        Rectified grey image.
    row : ndarray (K,) int
    x_px : ndarray (K,) float
        Boundaries from the mask, px.

    Returns
    -------
    ndarray (K,) float
        Refined boundaries (``x_px`` where the step is not clear).
    """
    x_px = np.asarray(x_px, float)
    if len(x_px) == 0:
        return x_px.copy()
    xi = np.rint(x_px).astype(np.int64)
    p = gather(gray, np.asarray(row, np.int64), xi[:, None] + np.arange(-3, 4))    # (K, 7) float32
    if gray.dtype == np.uint8:          # whole grey levels: the steps below in one compiled loop (the same values)
        return kernels_refine.refine_steps(p, x_px, xi, _LOG_STEPS, float(min_step), float(min_share), float(max_shift_px))
    raw = p[:, 5] + p[:, 6] - p[:, 0] - p[:, 1]            # twice the plateaus' difference, right - left
    step = np.diff(p, axis=1)
    step *= np.sign(raw)[:, None]                          # (K, 6): > 0 along the plateaus' step
    # difference j lies at xi - 2.5 + j: within 1.5 px of the boundary are j = 2, 3 and 1 or 4 (the
    # side the boundary leans to); 0 and 5 are only neighbours for the parabola
    d = (x_px - xi).astype(np.float32)
    cand = step[:, 1:5].copy()
    cand[d > 0, 0] = -np.inf
    cand[d < 0, 3] = -np.inf
    k = np.argmax(cand, axis=1) + 1
    flat = step.reshape(-1)
    at = np.arange(len(k)) * 6 + k
    a, b, c = flat[at - 1], flat[at], flat[at + 1]
    # peak of a Gaussian through the three (exact for a blurred step); a parabola where a side is <= 0
    la, lb, lc = (np.log(np.maximum(v, 1e-3)) for v in (a, b, c))
    gauss = (a > 0) & (c > 0)
    frac = np.where(gauss, 0.5 * (la - lc) / np.minimum(la - 2 * lb + lc, -1e-6),
                    0.5 * (a - c) / np.minimum(a - 2 * b + c, -1e-6))
    clear = (b >= min_step) & (b >= 0.5 * min_share * np.abs(raw)) & (b > a) & (b >= c)
    shift = k - 2.5 - d + frac
    return np.where(clear & (np.abs(shift) <= max_shift_px), x_px + shift, x_px)


def steep_boundaries(mask: np.ndarray, row: np.ndarray, x_px: np.ndarray, max_tan: float = 1.0) -> np.ndarray:
    """Whether the outline at each boundary runs within ``atan(max_tan)`` of the vertical, from the
    soft mask's central differences at the boundary's pixel (where a row crosses it cleanly).

    Parameters
    ----------
    mask : ndarray (H, W) uint8
        Soft mask (coverage 0-255).
    row : ndarray (K,) int
    x_px : ndarray (K,) float

    Returns
    -------
    ndarray (K,) bool
    """
    h, w = mask.shape
    r = np.minimum(np.maximum(row, 1), h - 2)               # (np.clip's values, without its overhead)
    c = np.minimum(np.maximum(np.rint(x_px).astype(np.int64), 1), w - 2)
    flat = mask.reshape(-1)
    at = r * w + c
    gx = np.abs(flat[at + 1].astype(np.int32) - flat[at - 1])
    gy = np.abs(flat[at + w].astype(np.int32) - flat[at - w])
    return gy <= max_tan * gx


def near_points(runs: Runs, xy_px: np.ndarray, reach_px: float, d_range_px=(0.0, 0.0), cell_px: int = 16) -> np.ndarray:
    """Runs near any of some points: within ``reach_px`` of a point's row, and of its column moved
    left by a disparity in its ``d_range_px`` (the right view's runs where the points may show).

    On a grid of ``cell_px`` cells (so up to a cell further), by the runs' middle pixel.

    Parameters
    ----------
    runs : Runs
    xy_px : ndarray (P, 2)
        Points (x, y), px (left rectified image).
    reach_px : float
    d_range_px : (2,) or ndarray (P, 2)
        Disparity range (lo, hi), px, of all points or of each.

    Returns
    -------
    ndarray (R,) bool
    """
    xy = np.asarray(xy_px, float).reshape(-1, 2)
    if len(xy) == 0 or len(runs.row) == 0:
        return np.zeros(len(runs.row), bool)
    d = np.broadcast_to(np.asarray(d_range_px, float), (len(xy), 2))
    rows, cols = int(runs.row[-1]) // cell_px + 1, runs.width // cell_px + 1
    box = np.column_stack([xy[:, 1] - reach_px, xy[:, 1] + reach_px,
                           xy[:, 0] - d[:, 1] - reach_px, xy[:, 0] - d[:, 0] + reach_px]) // cell_px
    box[:, [0, 2]] = np.maximum(box[:, [0, 2]], 0)
    if np.isfinite(box).all():          # compiled: the same cells and look-ups (kernels_match.runs_near)
        return kernels_match.runs_near(runs.row, runs.x0, runs.x1, box, rows, cols, int(cell_px))
    grid = np.zeros((rows, cols), bool)
    for y0, y1, x0, x1 in box.astype(np.intp).tolist():       # a few dozen points (a box left of or
        grid[y0:y1 + 1, x0:x1 + 1] = True                      # above the image is empty)
    return grid[runs.row // cell_px, np.minimum((runs.x0 + runs.x1) // (2 * cell_px), cols - 1)]


def grey_weight(dev_px: np.ndarray, grey_sd_px: float = GREY_SD_PX) -> float:
    """Weight of the grey step against the mask's (bias-corrected) boundary, from their differences.

    The two err independently: the differences' spread (1.4826 x their median absolute deviation,
    robust) squared is the sum of both variances; the grey's, ``grey_sd_px`` squared, is known
    (measured against the truth's outline, docs/localize-outline.md), so the mask's is the rest,
    and the least-variance mix weighs the grey by the mask's share of the sum. A binary mask
    (whole-pixel outline, spread ~0.28 px) gives ~0.87, the colour recogniser's soft outline
    (~0.14 px) ~0.5, a mask as good as the grey step or better 0.

    Parameters
    ----------
    dev_px : ndarray (K,)
        Grey step minus the mask's boundary, inward positive, bias removed, px.
    grey_sd_px : float

    Returns
    -------
    float
        0-1.
    """
    a = np.abs(dev_px - median(dev_px))
    var = (1.4826 * float(median(a))) ** 2 if len(a) else 0.0
    return max(var - grey_sd_px * grey_sd_px, 0.0) / var if var > 0 else 1.0


def whole_pixel_share(gray, row: np.ndarray, x_px: np.ndarray, max_samples: int = 256) -> float:
    """Share of boundaries lying within 0.1 px of a pixel boundary of the original (unrectified)
    image, along its rows: a binary mask's outline, remapped with linear interpolation, crosses
    one half there on steep outlines (measured: 0.66-0.83 of the steep boundaries with the exact
    binary masks, 0.25-0.33 with the colour recogniser's bark share; a uniform spread gives 0.2).

    Parameters
    ----------
    gray : ndarray (H, W) or LazyRectified
        The view's rectified grey image: a LazyRectified's remap tables give the original
        columns; an ndarray is taken as the original itself.
    row : ndarray (K,) int
    x_px : ndarray (K,) float
    max_samples : int
        At most this many boundaries are looked at (evenly spaced in the list).

    Returns
    -------
    float
    """
    x_px = np.asarray(x_px, float)
    if len(x_px) == 0:
        return 0.0
    step = -(-len(x_px) // max_samples)                    # (a share: a few hundred boundaries tell it)
    row, x_px = np.asarray(row)[::step], x_px[::step]
    sx = x_px
    if not isinstance(gray, np.ndarray):
        mx = gray.rectifier.float_maps(gray.side)[0]
        xi = np.minimum(np.maximum(np.floor(x_px).astype(np.int64), 0), mx.shape[1] - 2)
        f = x_px - xi
        r = np.asarray(row, np.int64)
        sx = mx[r, xi] * (1.0 - f) + mx[r, xi + 1] * f
    frac = (sx + 0.5) % 1.0
    return float(np.mean(np.minimum(frac, 1.0 - frac) < 0.1))


def refine_runs(runs: Runs, gray, mask: np.ndarray | None = None, only: np.ndarray | None = None,
                max_tan: float = STEEP_TAN, max_dev_px: float = 0.6, min_moved: int = 50, grey_sd_px: float = GREY_SD_PX,
                whole_dev_px: float | None = None, **kw) -> Runs | tuple[Runs, Runs | None]:
    """``runs`` with their boundaries moved to the grey image's outline (:func:`refine_boundaries`).

    A segmenter's mask sits off the grey outline by some bias (its threshold, its cleaning): all
    boundaries first move by the median shift of those the grey image moves (if at least
    ``min_moved``), then those move towards the grey outline (at most ``max_dev_px`` from there:
    the step's position is good, but a lit rim or the background's texture can pull it off), by
    the weight :func:`grey_weight` gives the grey step against the mask from how far the two
    scatter about each other (a soft outline such as the colour recogniser's bark share: ~0.5, the
    mean of two estimates of about equal error). A binary mask's outline (:func:`whole_pixel_share`
    at least ``WHOLE_PIXEL_SHARE``) goes to the grey step whole: its whole-pixel error is the
    same over many rows of a near-vertical outline, where a mix keeps part of it in every row. A
    boundary moved out into the next pixel takes that pixel into the run (:meth:`Runs.find` looks
    runs up by pixel), where at least two background pixels part it from the next run.

    Parameters
    ----------
    runs : Runs
        Runs of ``mask``.
    gray : ndarray (H, W) uint8 or LazyRectified
        The rectified grey image of the same view.
    mask : ndarray (H, W) uint8, optional
        The soft mask of the runs: only boundaries where the outline is steep enough are refined
        (:func:`steep_boundaries` with ``max_tan``, ``STEEP_TAN``: within 45 deg of the vertical;
        along a row a shallower outline's step is spread over pixels: 60 deg gained on the 28
        scenes and lost on 32 fresh ones, docs/localize-outline.md); all without it.
    only : ndarray (R,) bool, optional
        Runs to refine (the others only take the bias); all without it.
    grey_sd_px : float
        The grey step's own error (standard deviation, px) for :func:`grey_weight`.
    whole_dev_px : float, optional
        With it, also the runs with the boundaries moved to the grey step whole (within this of the
        mask's outline, px) where the mask's outline is soft (mixed with the grey step rather than moved
        to it: :func:`grey_weight` below 1), else None (a binary mask's: the runs themselves).
    **kw
        Passed to :func:`refine_boundaries`.

    Returns
    -------
    Runs, or (Runs, Runs or None) with ``whole_dev_px``
    """
    n = len(runs.row)
    if n == 0:
        return runs if whole_dev_px is None else (runs, None)
    # compiled: the numpy steps around the grey step, the same values (kernels_refine; the boundaries
    # refined, the moved ones' bias, whole_pixel_share, grey_weight's deviation, the mix and the runs)
    row, lp, rp = (np.ascontiguousarray(a, dt) for a, dt in ((runs.row, np.int64), (runs.left_px, float),
                                                              (runs.right_px, float)))
    todo, row_t, x_t = kernels_refine.refine_todo(
        row, lp, rp, _NO_ONLY if only is None else np.ascontiguousarray(only, np.bool_), only is not None,
        _NO_MASK if mask is None else np.ascontiguousarray(mask, np.uint8), mask is not None, float(max_tan))
    xr = np.ascontiguousarray(refine_boundaries(gray, row_t, x_t, **kw), float)
    has_map = not isinstance(gray, np.ndarray)
    mx = gray.rectifier.float_maps(gray.side)[0] if has_map else _NO_MAP
    sel, bias, share, mad = kernels_refine.refine_stats(row, lp, rp, todo, xr, mx, has_map, int(min_moved), 256)
    weight = 1.0
    moved = len(sel) >= min_moved
    if moved and share < WHOLE_PIXEL_SHARE:         # grey_weight's last steps (CPython's ** 2: libm's pow)
        var = (1.4826 * float(mad)) ** 2 if len(sel) else 0.0
        weight = max(var - grey_sd_px * grey_sd_px, 0.0) / var if var > 0 else 1.0
    rx0, rx1 = np.ascontiguousarray(runs.x0, np.int64), np.ascontiguousarray(runs.x1, np.int64)
    x0, x1, left, right = kernels_refine.refine_apply(row, rx0, rx1, lp, rp, int(runs.width), todo, xr, sel, float(bias),
                                                      moved, float(weight), float(max_dev_px))
    out = dataclasses.replace(runs, x0=x0, x1=x1, left_px=left, right_px=right)
    if whole_dev_px is None:
        return out
    if not (moved and share < WHOLE_PIXEL_SHARE):
        return out, None
    x0, x1, left, right = kernels_refine.refine_apply(row, rx0, rx1, lp, rp, int(runs.width), todo, xr, sel, float(bias),
                                                      moved, 1.0, float(whole_dev_px))
    return out, dataclasses.replace(runs, x0=x0, x1=x1, left_px=left, right_px=right)
