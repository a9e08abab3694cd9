"""A fork's child along the rows, checked by its bark texture.

A fork is reported only if the child is at the parent's depth there (else two branches merely
cross in the image). A child within a few degrees of the rows cannot show it by its outline: a
child at another depth is moved along the rows in the right view, that is along itself, and
leaves the parent's outline at the same place (``EndPlacer._outline_agrees`` refuses to tell);
its rows' crossings run along it and carry no disparity either. What pins a branch along the rows
is its bark texture, as for the flat pieces (``texture.surface_disparity``): the child's patches
next to the fork, clear of the parent, must match at the fork's disparity.
"""

from __future__ import annotations

import numpy as np
from appliance.localize import kernels_forknear, kernels_forks
from appliance.localize.texture import axis_to_surface, surface_disparity, surface_to_axis

# disparities searched either side of the fork's (px): a crossing branch at another depth finds its
# own match there, or none that correlates
SEARCH_PX = 8.0
MIN_SCORE = 0.6                 # correlation of a patch that counts (as forkdisp.flat_side_near)
MIN_PATCHES = 3                 # patches that must agree with the fork's disparity ...
MIN_SHARE = 0.6                 # ... and their share of those that correlate
STEP_PX = 2.0                   # patches this far apart along the child's line ...
REACH_PX = 8.0                  # ... over this much of it, from where it is clear of the parent


def child_texture_agrees(left_gray, right_gray, c_px: np.ndarray, e: np.ndarray, s0_px: float, d_px: float,
                         r_child_px: float, f_px: float, offset_px: float = 0.0) -> bool:
    """Whether a child's bark texture next to its fork matches at the fork's disparity.

    Patches on the child's centre line where it is first clear of the parent, matched along the
    rows (``texture.surface_disparity``, within ``SEARCH_PX`` of the fork's disparity) and moved
    back onto the axis, must give the fork's disparity: at least ``MIN_PATCHES`` of them, and
    ``MIN_SHARE`` of those correlating at ``MIN_SCORE``, within 1 px or 0.6 %. (Not carried to
    the fork along a line through them: over the 10-40 px from the fork to the first patch
    clear of the parent, their scatter is multiplied; a child pointing steeply in depth, whose
    disparity there already differs, is left withheld.)

    Parameters
    ----------
    left_gray, right_gray : array-like (H, W)
        Rectified grey images (sliceable: read over the patches' box only).
    c_px, e : ndarray (2,)
        The fork (x, y) and the child's unit direction away from it.
    s0_px : float
        Where along ``e`` the child is first seen clear of the parent (px from the fork).
    d_px : float
        The fork's disparity (on the axis).
    r_child_px : float
        The child's radius (px): patches span rows +-0.6 of it.
    f_px, offset_px : float
        Focal length and the rectified principal-point difference (``texture.surface_to_axis``).
    """
    s = s0_px + np.arange(0.0, REACH_PX + 1e-9, STEP_PX)
    pts = np.asarray(c_px, float) + s[:, None] * np.asarray(e, float)
    hh = max(1, int(0.6 * r_child_px))
    # the axis' disparity on the surface the patches see (surface_to_axis inverted; its depth fraction,
    # surface_to_axis' own default, reused below; compiled: kernels_forknear.depth_fraction)
    frac = np.float64(kernels_forknear.depth_fraction(float(r_child_px), hh))    # (patch_depth_fraction's value)
    d_s = axis_to_surface(d_px, r_child_px, f_px, offset_px, frac)
    d, score = surface_disparity(left_gray, right_gray, pts, np.full(len(pts), hh),
                                 (d_s - SEARCH_PX, d_s + SEARCH_PX))
    # (a best match at the search's end is no peak: the texture matches further out, or nowhere)
    ok = np.isfinite(d) & (score >= MIN_SCORE) & (np.abs(d - d_s) < SEARCH_PX - 0.5)
    n_good = int(np.count_nonzero(ok))
    if n_good < MIN_PATCHES:
        return False
    d_ax = surface_to_axis(d[ok], r_child_px, f_px, offset_px, depth_fraction=frac)
    n_ok = int(np.count_nonzero(np.abs(d_ax - d_px) <= max(1.0, 0.006 * abs(d_px))))
    return n_ok >= MIN_PATCHES and n_ok >= MIN_SHARE * n_good


# a child without a curve whose bark texture beyond the parent matches clearly at another depth leaves another branch
# (one hidden beside the parent in the image, at another depth): searched this far either side of the fork's (px) ...
ELSEWHERE_SEARCH_PX = 30.0
ELSEWHERE_PX = 6.0              # ... its patches all this far (px) or more off the fork's disparity, on one side
ELSEWHERE_REACH_PX = 16.0       # ... over this much of the child's line past the parent's outline (px)


def child_texture_elsewhere(left_gray, right_gray, c_px: np.ndarray, e: np.ndarray, s0_px: float, d_px: float,
                            r_child_px: float, f_px: float, offset_px: float = 0.0) -> bool:
    """Whether a child's bark texture past the parent's outline matches clearly at another depth than the fork's.

    Patches on the child's line from where it leaves the parent's outline (``s0_px``) over ``ELSEWHERE_REACH_PX``,
    ``STEP_PX * 2`` apart, are matched along the rows within ``ELSEWHERE_SEARCH_PX`` of the fork's disparity and moved
    back onto the axis (``texture.surface_to_axis``). At least ``MIN_PATCHES`` correlating at ``MIN_SCORE`` (not at
    the search's ends), all of them ``ELSEWHERE_PX`` or more off the fork's disparity on the same side: the child is
    at another depth where it leaves the parent (a branch hidden beside the parent in the image, at another depth,
    whose fork it is: seed 642's fork 7, exact masks, the child 12-23 px behind the parent it seemed to leave).

    Parameters
    ----------
    left_gray, right_gray : array-like (H, W)
        Rectified grey images.
    c_px, e : ndarray (2,)
        The fork (x, y) and the child's unit direction away from it.
    s0_px : float
        Where along ``e`` the child leaves the parent's outline (px from the fork).
    d_px : float
        The fork's disparity (on the axis, px).
    r_child_px : float
        The child's radius (px): patches span rows +-0.6 of it.
    f_px, offset_px : float
        Focal length and the rectified principal-point difference (px).

    Returns
    -------
    bool
        True where the texture clearly matches at another depth; False where it agrees, is unclear or unread.
    """
    s = s0_px + np.arange(0.0, ELSEWHERE_REACH_PX + 1e-9, 2.0 * STEP_PX)
    pts = np.asarray(c_px, float) + s[:, None] * np.asarray(e, float)
    hh = max(1, int(0.6 * r_child_px))
    frac = np.float64(kernels_forknear.depth_fraction(float(r_child_px), hh))
    d_s = axis_to_surface(d_px, r_child_px, f_px, offset_px, frac)
    d, score = surface_disparity(left_gray, right_gray, pts, np.full(len(pts), hh),
                                 (d_s - ELSEWHERE_SEARCH_PX, d_s + ELSEWHERE_SEARCH_PX))
    ok = np.isfinite(d) & (score >= MIN_SCORE) & (np.abs(d - d_s) < ELSEWHERE_SEARCH_PX - 0.5)
    if int(np.count_nonzero(ok)) < MIN_PATCHES:
        return False
    off = surface_to_axis(d[ok], r_child_px, f_px, offset_px, depth_fraction=frac) - d_px
    return bool(np.all(off <= -ELSEWHERE_PX) or np.all(off >= ELSEWHERE_PX))


# a branch passing the parent (behind or in front, at about its depth) shows on the parent's far
# side along the child's line, within this far (px) of the parent's outline (past an apple or a leaf)
THROUGH_REACH_PX = 80.0


def passes_through(mask: np.ndarray, c_px: np.ndarray, e: np.ndarray, s_far_px: float, r_child_px: float) -> bool:
    """Whether a branch of the child's width runs on along the child's line on the parent's far side.

    A fork's child starts at the parent; a branch crossing the parent in the image goes on past it
    on the same line. Along ``c_px - s e`` for ``s`` from ``s_far_px`` (the parent's far outline
    along the line, px from the fork) over ``THROUGH_REACH_PX``, a sample is the branch's where the
    mask covers the line and leaves both sides clear (``1.5 r + 2`` px off it: a band no wider
    than the child); ``max(6, 1.5 r)`` such samples in a row pass through.

    Parameters
    ----------
    mask : ndarray (H, W) uint8
        The left view's branch coverage (0-255).
    c_px, e : ndarray (2,)
        The fork (x, y) and the child's unit direction away from it.
    s_far_px : float
        Where the parent's far outline lies along ``-e`` (px from the fork).
    r_child_px : float
        The child's radius (px).
    """
    # (compiled: kernels_forks.passes_through, the same samples and reads, stopping at the first run)
    return kernels_forks.passes_through(np.ascontiguousarray(mask), np.ascontiguousarray(c_px, float),
                                        np.ascontiguousarray(e, float), float(s_far_px), float(r_child_px),
                                        THROUGH_REACH_PX)
