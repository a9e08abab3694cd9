"""A thin branch crossing in front of a thick one, taken for a fork (seed 910 T10).

Where a thin branch lies across a trunk in front of it, the masks merge the two and the skeleton
joins the thin branch's centre line to the trunk's: a junction whose two trunk pieces run straight
through it with like radius and whose third piece is several times thinner. A true thin child off
a thick parent looks the same in the mask (its axis ends at the parent's axis too). What tells
them apart is the thin piece's depth where it meets the parent: a child's axis starts on the
parent's axis, at the parent's disparity; a branch lying across the parent's front meets it at
the parent's front surface, about one parent radius nearer. In disparity that step is
``d r / f`` (``d`` the parent's disparity, ``r`` its radius in px, ``f`` the focal length in px:
Z_front = Z (1 - R / Z) with R / Z = r / f), 5.1 px for 910 T10's trunk (r 36 px, d 204 px).

The thin piece's own curve carried to the junction says which: seed 910's node 6 (exact masks),
+3.13 px in front of the trunk's disparity (0.62 of the step; the truth +4.94), seed 132's node 6
(a false fork of the same kind), +3.44 px (0.63). True forks of the geometry (the parent pair
straight and alike, the child at most ``THIN_SHARE`` of the parent's radius) were not seen on
the sets (900-931, the 60 scenes, 484-547: the thinnest correct fork's child 0.33 of its parent, seed
538 T3, whose child curve is carried wild, +65 px: beyond ``MAX_STEP_SHARE``).

Such a node's feature is where the thin branch meets the parent's front surface: ``forkends`` places it at
``d + front_step_px`` (910 T10: 209.42 px against the truth's 209.32, -0.38 mm; the child's curve, 207.52, would
be 1.8 px short), or withholds it (``forkends.CROSSING_IN_FRONT_PLACED`` off).
"""

from __future__ import annotations

# the parent's two pieces run straight through the node: their directions away from it at least this opposed
# (cosine of the angle between them at most minus this) ...
STRAIGHT_COS = 0.95
# ... with like radius (the thinner at least this share of the thicker) ...
LIKE_RADIUS = 0.8
# ... and the third piece several times thinner (its radius at most this share of the thinner side's)
THIN_SHARE = 0.3
# the thin piece's curve at the node in front of the parent's disparity by this share of the parent's front-surface
# step d r / f or more (a crossing in front), and by no more than MAX_STEP_SHARE of it (further: a wild curve)
MIN_STEP_SHARE = 0.4
MAX_STEP_SHARE = 1.5
MIN_FRONT_PX = 1.0          # ... and by at least this (px): a thin parent's step is within the curves' noise


def front_step_px(d_px: float, r_px: float, f_px: float) -> float:
    """Disparity (px) of a branch's front surface over its axis' at disparity ``d_px``: ``d_px r_px / f_px``.

    Parameters
    ----------
    d_px : float
        The axis' disparity (px).
    r_px : float
        The branch's radius in the image (px).
    f_px : float
        Focal length (px).
    """
    return d_px * r_px / f_px


def crossing_in_front(r_sides_px: tuple[float, float], cos_sides: float, r_child_px: float, d_fork_px: float,
                      d_child_px: float | None, f_px: float) -> bool:
    """Whether a fork's node is a thin branch crossing in front of its parent, not a fork.

    True when the parent's two pieces run straight through the node (the cosine of the angle between their
    directions away from it ``cos_sides`` at most ``-STRAIGHT_COS``) with like radius (``LIKE_RADIUS``), the
    child is at most ``THIN_SHARE`` of the thinner side's radius, and the child's own curve at the node,
    ``d_child_px``, lies in front of the fork's disparity ``d_fork_px`` by ``MIN_STEP_SHARE`` ..
    ``MAX_STEP_SHARE`` of the parent's front-surface step (:func:`front_step_px` of the thicker side) and by at
    least ``MIN_FRONT_PX``: the thin branch meets the parent at its front surface, not at its axis.

    Parameters
    ----------
    r_sides_px : (float, float)
        The parent's two pieces' radii next to the node (px).
    cos_sides : float
        Cosine of the angle between the two pieces' directions away from the node.
    r_child_px : float
        The child's radius next to the node (px).
    d_fork_px : float
        The fork's disparity (the parent's, px).
    d_child_px : float or None
        The child's curve's disparity at the fork (px); None: no curve reaches it (False).
    f_px : float
        Focal length (px).
    """
    if d_child_px is None:
        return False
    r_lo, r_hi = min(r_sides_px), max(r_sides_px)
    if cos_sides > -STRAIGHT_COS or r_lo < LIKE_RADIUS * r_hi or r_child_px > THIN_SHARE * r_lo:
        return False
    step = front_step_px(d_fork_px, r_hi, f_px)
    front = d_child_px - d_fork_px
    return front >= max(MIN_FRONT_PX, MIN_STEP_SHARE * step) and front <= MAX_STEP_SHARE * step
