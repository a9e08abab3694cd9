"""The parent's axis at a fork from its own outline (where the fork is placed, issue 5).

Near a crotch the parent's centre line (skeleton or fitted row middles) is pulled towards the
child: the child widens the silhouette on its side from where its back edge leaves the parent's
outline to where its front edge does. Cross-sections of the parent square to its axis, taken on
both sides of the fork outside that stretch, cross the parent alone; the middles of those whose
width is the parent's own lie on its axis (its two edges are parallel).
"""

from __future__ import annotations

import numpy as np

from appliance.localize import kernels_forks

# cross-sections per side, and their spacing (parent radii, at least this many px)
SECTIONS = 4
SECTION_STEP_R = 0.5
SECTION_STEP_MIN_PX = 3.0
# a section is the parent's alone when its width is within this of the parent's (fraction of the
# width, plus px): a child or an occluder merged with it widens it, a leaf narrows it
WIDTH_TOL = 0.25
WIDTH_TOL_PX = 2.0
# a section's middle further from the placed line than this (parent radii) is another shape's
MIDDLE_MAX_R = 0.5
# ... and within this of the sections' median width (fraction, plus px)
SAME_WIDTH = 0.08
SAME_WIDTH_PX = 1.5
# middles further than this from the line through all (px) are left out once (if 3 stay)
MIDDLE_OFF_PX = 1.0
# the axis taken only within this of the line it corrects (sine of the angle)
MAX_TURN_SIN = 0.10


def axis_params() -> tuple:
    """This module's constants in :func:`kernels_forks.parent_axis`' order (read when called)."""
    return (SECTIONS, SECTION_STEP_R, SECTION_STEP_MIN_PX, WIDTH_TOL, WIDTH_TOL_PX, MIDDLE_MAX_R, SAME_WIDTH,
            SAME_WIDTH_PX, MIDDLE_OFF_PX, MAX_TURN_SIN)


def parent_axis(mask: np.ndarray, xy: np.ndarray, e1: np.ndarray, out: np.ndarray, r_behind: float,
                r_ahead: float, r_child: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The parent's axis (centroid, unit direction) from its cross-sections clear of the crotch.

    ``xy`` (2,): the fork as placed on the parent's line of direction ``e1`` (2,); ``out`` (2,):
    the child's direction away from it; ``r_behind``, ``r_ahead``: the parent's radius (px) on
    the side opposite the child and on the child's side; ``r_child``: the child's (px).

    With the parent along x, the child leaving at angle a from the fork F, the child's back
    edge leaves the parent's outline at ``(r_child - R cos a) / sin a`` behind F (if positive) and
    its front edge at ``(R cos a + r_child) / sin a`` ahead of it: sections from half a parent
    radius (+3 px, for the fork's own place being a few px off) beyond those are the parent's
    alone. None when fewer than three sections hold, or the axis turns more than
    ``MAX_TURN_SIN`` from ``e1``.

    Each section (``SECTIONS`` per side, ``SECTION_STEP_R`` radii apart) is read on +-(2.5 r + 4) px
    square to the axis, 1 px apart (bilinear); its run of coverage >= 128 through (or nearest within
    ``MIDDLE_MAX_R`` r + 1 px of) the line, ends interpolated at 128, is kept when its width is the
    parent's ``2 r`` (px) within ``WIDTH_TOL`` (and ``WIDTH_TOL_PX``), its middle within
    ``MIDDLE_MAX_R`` r + 1 px of the line, and its width within ``SAME_WIDTH`` (and ``SAME_WIDTH_PX``)
    of the kept sections' median width. A total-least-squares line through the kept middles is the
    axis (middles further than ``MIDDLE_OFF_PX`` from it left out once, if 3 stay). Compiled whole:
    :func:`kernels_forks.parent_axis`.
    """
    found, c, ea = kernels_forks.parent_axis(
        np.ascontiguousarray(mask), np.asarray(xy, float), np.asarray(e1, float), np.asarray(out, float),
        float(r_behind), float(r_ahead), float(r_child), *axis_params())
    return (c, ea) if found else None
