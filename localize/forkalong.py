"""A fork whose child lies along its parent in the image, placed from the merged silhouette (issue 5).

A child leaving its parent at a shallow image angle (5-30 deg) stays inside the parent's silhouette
for tens of px: the skeleton's junction forms where the two outlines part, 40-130 px past the fork,
and the child's outline there is too close to the parent's for two crossings to give its axis
(:meth:`forkends.ForkPlacing._fork_from_child_outline`). Along the merged piece, though, the child's
outer outline is one straight line from where it leaves the parent's outline (the widening's onset)
through the parting and on; past the parting the child's inner outline is a second, parallel one.
Measured against the parent's axis (its far outline, unaffected by the child, plus half its own
width), the two give the child's axis over 60-130+ px, and where it crosses the parent's axis is the
fork. With the parent along s and the child leaving at angle a, the outer outline lies at
``s tan a + r_c / cos a`` from the parent's axis, the inner at ``s tan a - r_c / cos a``; their mean
is zero at the fork (s = 0).

Sections square to the parent's line are read on the soft mask (bilinear, ends interpolated where the
coverage crosses 128), one per px of s: the parent's run (through its axis), its far end, its near
end, and the child's run beyond it once the two have parted.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.linalg import _umath_linalg

from appliance.localize import kernels_walks
from appliance.localize.curves import median

_EPS = float(np.finfo(np.float64).eps)

# sections from this far behind the junction (px) to this far ahead of it
BACK_PX = 170.0
AHEAD_PX = 50.0
# the child's angle to the parent (deg) this rule reads, the skeleton lines' (10-30 deg off at a shallow crotch)
# and the outer outline's own: shallower, 1 px across moves the place 5+ px along the parent (seed 542's fork 3 at
# 11 deg: 22 px off); steeper, the child's own outline places it (forkends)
MIN_DEG = 12.0
MAX_DEG = 50.0
# a parent thinner than this (radius, px) is not read: its widening (1.5 px) is a quarter of its radius, within
# its sections' noise (seed 682's fork 11, colour masks: r 6 px, placed 6.2 px off, a false fork)
MIN_PARENT_RADIUS_PX = 8.0
# a section is widened by the child where its width exceeds the parent's by this (px)
WIDEN_PX = 1.5
# at least this many sections on the parent's far outline next to the junction (its direction), this many
# merged (widened) in one stretch ending at the parting, and this many parted ones in a row (the child's own run
# beside the parent's)
MIN_OUTER = 30
MIN_WIDENED = 15
MIN_PARTED = 8
# ... the parting looked for from this far behind the junction on (px)
PART_FROM_PX = 30.0
# the child's outer outline read over this far past the widening's onset (px), at least MIN_LOCAL sections
LOCAL_PX = 30.0
MIN_LOCAL = 12
# the outer outline's line crosses the parent's outline at most this (px, across) further back than the
# widening's onset would have it (the onset: WIDEN_PX wider than the parent)
ONSET_TOL_PX = 1.0
# the outer outline's sections further than this from its line (px) are left out once; the rest must
# scatter within OUTER_RMS_PX (a bent child or a leaf in the stretch: unclear)
OUTER_OFF_PX = 1.0
OUTER_RMS_PX = 0.6
# the child's radius measured past the parting within this of the skeleton's (fraction, plus half the px)
CHILD_WIDTH_TOL = 0.35
CHILD_WIDTH_TOL_PX = 2.0
# the place found must lie this far (px) inside the sections read, with as many parent-alone sections behind it
BEHIND_MARGIN_PX = 10.0
# the child's line past the parting (its run's middles) must agree in angle with the outer outline's next to
# the onset within this (deg): a child of another direction there is another shape merged with the parent
ANGLE_TOL_DEG = 8.0


def sections(mask: np.ndarray, base: np.ndarray, e: np.ndarray, n: np.ndarray, s: np.ndarray, t: np.ndarray,
             gap_px: float) -> dict:
    """The runs on sections square to a line (``base`` + s ``e``), ``t`` along ``n`` (toward the child).

    ``mask`` (uint8, 0-255) is read bilinear (cv2.remap's value) at ``base + s e + t n``, each section only as
    far as its runs go (compiled: :func:`kernels_walks.section_runs`). Returns arrays over ``s``: ``ok`` (the
    line's point on the mask), ``lo`` / ``hi`` (the ends of the run through t = 0, px along n, sub-pixel: where
    the coverage crosses 128 between samples), ``child`` (a further run starting within ``gap_px`` of ``hi``),
    ``cl`` / ``ch`` (its ends; NaN where none).
    """
    i0 = int(np.abs(t).argmin())
    ok, lo, hi, child, cl, ch = kernels_walks.section_runs(
        mask, np.ascontiguousarray(base, np.float64), np.ascontiguousarray(e, np.float64),
        np.ascontiguousarray(n, np.float64), np.ascontiguousarray(s, np.float64),
        np.ascontiguousarray(t, np.float64), i0, float(gap_px))
    return {"ok": ok, "lo": lo, "hi": hi, "child": child, "cl": cl, "ch": ch}


def polyfit_line(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """``np.polyfit(x, y, 1)`` (slope, intercept) of float64 1-D arrays: numpy's own steps (the scaled
    Vandermonde matrix [x, 1], LAPACK's least squares through ``_umath_linalg.lstsq`` with polyfit's rcond,
    the scale divided out), the same values without its and ``lstsq``'s argument handling (~30 % faster: the
    SVD dominates; no RankWarning for a rank-deficient fit, whose values are polyfit's); ``np.polyfit`` itself
    where LAPACK gives no finite answer (its error or warning then)."""
    n = len(x)
    lhs = np.empty((n, 2))
    lhs[:, 0] = x
    lhs[:, 1] = 1.0
    scale = np.sqrt((lhs * lhs).sum(axis=0))
    lhs /= scale
    c = _umath_linalg.lstsq(lhs, y[:, None], n * _EPS, signature="ddd->ddid")[0][:, 0] / scale
    if not np.isfinite(c).all():
        return tuple(np.polyfit(x, y, 1).tolist())
    return float(c[0]), float(c[1])


def _line_fit(x: np.ndarray, y: np.ndarray, off_px: float) -> tuple[float, float, np.ndarray] | None:
    """Least-squares line y = a + k x; points further than ``off_px`` left out once. (a, k, kept)."""
    if len(x) < 3:
        return None
    k, a = polyfit_line(x, y)
    keep = np.abs(y - (a + k * x)) <= off_px
    if keep.sum() >= max(3, len(x) // 2) and not keep.all():
        k, a = polyfit_line(x[keep], y[keep])
    return a, k, keep


def _no(diag: dict | None, why: str) -> None:
    """None, the reason kept in ``diag`` (the tracer's)."""
    if diag is not None:
        diag["why"] = why
    return None


def along_fork(mask: np.ndarray, p: np.ndarray, e_par: np.ndarray, out: np.ndarray, r_par: float,
               r_child: float, diag: dict | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The fork of a child lying along its parent, from the merged silhouette: None when unclear.

    ``p`` (2,): the skeleton junction where the two outlines part (px, x y); ``e_par`` (2,): the parent's
    direction there; ``out`` (2,): the child's direction away from it; ``r_par``, ``r_child``: their radii
    (px, rough: the parent's width is measured, the child's checked). Returns the fork (2,), a point on
    the parent's axis there and its direction (the parent's line for the checks that follow), or None:
    the child's angle outside ``MIN_DEG``-``MAX_DEG``, too few sections on either outline, the outer
    outline not straight, the child's width not its own, or the place outside the sections read.
    ``diag``: filled with the intermediate values (for the tracer).
    """
    e = np.asarray(e_par, float) / max(float(np.hypot(*e_par)), 1e-12)
    out = np.asarray(out, float) / max(float(np.hypot(*out)), 1e-12)
    if np.dot(e, out) < 0:
        e = -e
    n = np.array([-e[1], e[0]])
    if np.dot(n, out) < 0:
        n = -n
    sin_a = float(abs(e[0] * out[1] - e[1] * out[0]))
    ang = math.degrees(math.asin(min(sin_a, 1.0)))
    if r_par < MIN_PARENT_RADIUS_PX:
        return _no(diag, "a thin parent")
    if not MIN_DEG <= ang <= MAX_DEG:
        return _no(diag, "not MIN_DEG <= ang <= MAX_DEG")
    p = np.asarray(p, float)
    t_far = -(2.5 * r_par + 6.0)
    t_near = 2.5 * r_par + 4.0 * r_child + AHEAD_PX * math.tan(math.radians(MAX_DEG)) + 10.0
    t = np.arange(math.floor(t_far), math.ceil(t_near) + 1.0, 1.0)
    # pass 1: the parent's direction from its far outline near the junction (the skeleton's line there is
    # pulled towards the child)
    s1 = np.arange(-min(BACK_PX, 80.0), AHEAD_PX + 1.0, 1.0)
    sec = sections(mask, p, e, n, s1, t, 4.0 * r_child + 10.0)
    ok = sec["ok"]
    if ok.sum() < MIN_OUTER:
        return _no(diag, "ok.sum() < MIN_OUTER")
    fit = _line_fit(s1[ok], sec["lo"][ok], OUTER_OFF_PX)
    if fit is None:
        return _no(diag, "fit is None")
    a_lo, k_lo, _ = fit
    if abs(k_lo) > 0.2:
        return _no(diag, "abs(k_lo) > 0.2")
    e2 = (e + k_lo * n) / math.hypot(1.0, k_lo)
    n2 = np.array([-e2[1], e2[0]])
    if np.dot(n2, n) < 0:
        n2 = -n2
    w0 = float(median((sec["hi"] - sec["lo"])[ok & sec["child"]])) if (ok & sec["child"]).any() else 2.0 * r_par
    base = p + (a_lo + 0.5 * w0) * n         # the parent's axis near the junction
    e, n = e2, n2
    sin_a = float(abs(e[0] * out[1] - e[1] * out[0]))
    # pass 2: the sections along the corrected line
    s = np.arange(-BACK_PX, AHEAD_PX + 1.0, 1.0)
    t = t - (a_lo + 0.5 * w0)
    t = t[t >= -(1.5 * r_par + 6.0)]
    sec = sections(mask, base, e, n, s, t, 4.0 * r_child + 10.0)
    ok, child = sec["ok"], sec["child"]
    if diag is not None:
        diag.update(s=s, base=base, e=e, n=n, **sec)
    # the parting: from there on the child's run lies beside the parent's (the first MIN_PARTED in a row
    # from PART_FROM_PX behind the junction on), for as long as it does
    run = np.convolve(child.astype(np.int64), np.ones(MIN_PARTED, np.int64), "valid") == MIN_PARTED
    run[: int(np.searchsorted(s, -PART_FROM_PX))] = False
    if not run.any():
        return _no(diag, "no parting")
    i_part = int(np.argmax(run))
    i_end = i_part + int(np.argmin(child[i_part:])) if not child[i_part:].all() else len(s)
    parted = np.zeros(len(s), bool)
    parted[i_part:i_end] = True
    parted &= ok
    lo_fit = _line_fit(s[ok], sec["lo"][ok], OUTER_OFF_PX)
    if lo_fit is None:
        return _no(diag, "lo_fit is None")
    lo_line = lo_fit[0] + lo_fit[1] * s
    width = sec["hi"] - lo_line
    # the parent's own width: the parted sections', and the merged ones behind that are not wider (a line: taper)
    w_par = float(median(width[parted]))
    alone = parted.copy()
    merged = ok & ~parted
    alone |= merged & (np.abs(width - w_par) <= WIDEN_PX)
    wf = _line_fit(s[alone], width[alone], OUTER_OFF_PX)
    if wf is None:
        return _no(diag, "wf is None")
    w_line = wf[0] + wf[1] * s
    if np.any(np.abs(w_line[ok] - w_par) > 0.5 * w_par):
        return _no(diag, "np.any(np.abs(w_line[ok] - w_par) > 0.5 * w_par)")
    axis = lo_line + 0.5 * w_line                      # the parent's axis (t) at each section
    widened = merged & (width - w_line > WIDEN_PX)
    # the widened sections must be one stretch ending at the parting
    if widened.sum() < MIN_WIDENED:
        return _no(diag, "widened.sum() < MIN_WIDENED")
    not_w = np.flatnonzero(~widened[:i_part])
    i_on = int(not_w[-1]) + 1 if len(not_w) else 0     # the widened stretch that ends at the parting
    if i_part - i_on < MIN_WIDENED:
        return _no(diag, "widened stretch short")
    outer = np.where(parted, sec["ch"], sec["hi"]) - axis
    # the child's outer outline next to the onset (a child's axis bends: the line over its first LOCAL_PX only)
    idx = np.arange(len(s))
    use = (widened | parted) & (idx >= i_on) & (s <= s[i_on] + LOCAL_PX)
    if use.sum() < MIN_LOCAL:
        return _no(diag, "few sections next to the onset")
    of = _line_fit(s[use], outer[use], OUTER_OFF_PX)
    if of is None:
        return _no(diag, "no outer line")
    a_out, k_out, keep = of
    res = (outer[use] - (a_out + k_out * s[use]))[keep]
    if float(np.sqrt(np.mean(res ** 2))) > OUTER_RMS_PX or k_out <= 0:
        return _no(diag, "outer outline not straight")
    ang_out = math.degrees(math.atan(k_out))
    if not MIN_DEG <= ang_out <= MAX_DEG:
        return _no(diag, "outer outline's angle")
    # the child's radius from its own run past the parting (its width across the parent's sections, at its
    # angle there)
    mid = 0.5 * (sec["cl"] + sec["ch"]) - axis
    mf = _line_fit(s[parted], mid[parted], OUTER_OFF_PX)
    if mf is None or mf[1] <= 0:
        return _no(diag, "no child line past the parting")
    if abs(math.degrees(math.atan(mf[1])) - ang_out) > ANGLE_TOL_DEG:
        return _no(diag, "the child past the parting not along the outer outline")
    r_c = float(median(0.5 * (sec["ch"] - sec["cl"])[parted])) * math.cos(math.atan(mf[1]))
    if abs(r_c - r_child) > CHILD_WIDTH_TOL * r_child + 0.5 * CHILD_WIDTH_TOL_PX:
        return _no(diag, "the child's width")
    b_in = a_out - 2.0 * r_c / math.cos(math.atan(k_out))
    s_f = -(0.5 * (a_out + b_in)) / k_out
    if diag is not None:
        diag.update(i_part=i_part, i_on=i_on, w_line=w_line, axis=axis, a_out=a_out, k_out=k_out, b_in=b_in,
                    s_f=s_f, outer=outer, widened=widened, parted=parted, r_c=r_c, k_mid=mf[1],
                    rms=float(np.sqrt(np.mean(res ** 2))),
                    s_x=(0.5 * float(np.interp(s[i_on], s, w_line)) - a_out) / k_out)
    # the outer line meets the parent's outline where the widening starts (a bent child, a bent parent or
    # another shape merged there: the line's crossing lies elsewhere)
    s_x = (0.5 * float(np.interp(s[i_on], s, w_line)) - a_out) / k_out
    if k_out * (s[i_on] - s_x) > WIDEN_PX + ONSET_TOL_PX or s_x > s[i_on] + 1.0:
        return _no(diag, "the outer line does not meet the parent's outline at the onset")
    if not s[0] + BEHIND_MARGIN_PX <= s_f <= s[i_on]:
        return _no(diag, "not s[0] + BEHIND_MARGIN_PX <= s_f <= s[i_on]")
    # (the sections behind the fork are the parent's alone)
    i_f = int(np.searchsorted(s, s_f))
    back = ok[:i_f] & ~widened[:i_f]
    if back.sum() < BEHIND_MARGIN_PX:
        return _no(diag, "back.sum() < BEHIND_MARGIN_PX")
    ax_f = float(np.interp(s_f, s, axis))
    xy = base + s_f * e + ax_f * n
    c_ax = base + axis[i_f] * n + s[i_f] * e
    return xy, c_ax, e
