"""Whether a parent side's fitted span vouches for its disparity at a fork by its own length.

:meth:`forkends.ForkPlacing._known_disparity` counts a piece's curve as known at the fork when it is carried no
further past its fitted span than half that span, or 12 px (px of its parameter: rows or columns) whichever is
more. The 12 px floor lets a fit on a few rows vouch for more than its own half span: a side fitted on 13 rows
and carried 9.5 rows to the fork (seed 512's fork 9, exact masks: its end slope carried, 4.15 px off, +22 mm)
or on 9 rows carried 9.9 (seed 458's fork 4, colour masks: 3.1 px off) then replaced the median of three
readings (the two sides and the child) that was right within 0.7 px. Such a side is not known there by its
own span: it does not override the others (:func:`known_side_stands`).
"""

from __future__ import annotations

from appliance.localize.flatfit import FEW_PATCHES


def vouched_by_span(t_range: tuple[float, float], t_fork: float) -> bool:
    """Whether a curve fitted on ``t_range`` (lo, hi; px of its parameter) is carried to ``t_fork`` (px) no
    further than half its span past it (inside the span: True)."""
    lo, hi = t_range
    return max(lo - t_fork, t_fork - hi, 0.0) <= 0.5 * (hi - lo)


def known_side_stands(d_known: float, sides: dict) -> bool:
    """Whether the disparity ``d_known`` (px) that :meth:`_known_disparity` chose may stand.

    ``sides``: {piece: (disparity at the fork px, (lo, hi) fitted span, the fork's parameter px)} of the
    parent sides not read from their own crossings or texture next to the fork. False when ``d_known`` is
    one of those sides' disparity and that side is carried past half its span (known only by the 12 px
    floor): the fork then keeps the disparity it had (the sides' mean or the median of three).
    """
    for d_s, t_range, t_fork in sides.values():
        if d_s == d_known and not vouched_by_span(t_range, t_fork):
            return False
    return True


def none_vouched(pieces: dict, read_near: bool) -> bool:
    """Whether none of a fork's pieces is known at it: ``pieces`` {piece: ((lo, hi) fitted span, the fork's
    parameter px)} (the parent sides and the child with curves), none vouched for by its span
    (:func:`vouched_by_span`), and no side read from its own crossings or texture next to the fork
    (``read_near`` False). Where the two parent sides also clearly disagree (the fork took the median of the
    three readings) nothing tells its disparity: seed 512's fork 9, sides fitted on 3-14 rows and carried
    9-13 rows, 6.6 and 4.2 px off on either side of the truth, the child carried 24-26 rows past its
    43-row span (0.7 px off, -3.7 mm with either mask source)."""
    return not read_near and not any(vouched_by_span(t_range, t_fork) for t_range, t_fork in pieces.values())


# a lone flat parent side's disparity at a fork is out-voted by the child's curve and the child's right outline
# when those two agree within OUTVOTE_AGREE_PX and both lie more than OUTVOTE_MIN_PX from it on the same side
OUTVOTE_AGREE_PX = 0.5
OUTVOTE_MIN_PX = 0.5
# ... and no further than this (px; forkends.OUTLINE_MAX_SHIFT_PX's 2 px): further, the child is another branch
# crossing the parent at another depth, not a fork (seed 298: 27 px)
OUTVOTE_MAX_PX = 2.0


def outvoted(d_side: float, d_child: float, d_outline: float) -> bool:
    """Whether a lone flat parent side's disparity ``d_side`` at a fork (px; its curve or its texture read next
    to the fork) is out-voted by two independent readings there: the child's curve ``d_child`` and the child's
    outline in the right view ``d_outline`` agree within ``OUTVOTE_AGREE_PX`` and both lie more than
    ``OUTVOTE_MIN_PX`` (and at most ``OUTVOTE_MAX_PX``) from ``d_side`` on the same side. Seed 378's fork 11 (exact masks): a flat parent's
    texture fit 0.78 px low along its whole 200 columns (+6.9 mm), the child +0.97, the outline +0.86."""
    a, b = d_child - d_side, d_outline - d_side
    return a * b > 0 and OUTVOTE_MIN_PX < min(abs(a), abs(b)) and max(abs(a), abs(b)) <= OUTVOTE_MAX_PX \
        and abs(d_child - d_outline) <= OUTVOTE_AGREE_PX


# a lone flat parent side's texture read next to a fork, scattered (its patches' scaled MAD over READ_SCATTER_PX),
# that the child's right outline contradicts by more than READ_OUTLINE_PX, the child's curve not confirming it
READ_SCATTER_PX = 0.3
READ_OUTLINE_PX = 2.0


def scattered_read_contradicted(d_fork: float, read_mad_px: float, d_outline: float | None,
                                child_confirms: bool) -> bool:
    """Whether a fork whose disparity ``d_fork`` (px) is a lone flat parent side's texture read next to it,
    its patches scattered (scaled MAD ``read_mad_px`` over ``READ_SCATTER_PX``), is contradicted by the
    child's outline in the right view (``d_outline`` more than ``READ_OUTLINE_PX`` away; None: no outline)
    with the child's curve not confirming the read (``child_confirms`` False): two independent readings
    of the fork's depth apart beyond the outline's noise (correct forks: up to 2.4 px), the one taken not
    consistent in itself, nothing third to tell. Seed 528's fork 14 (colour masks): 4 patches next to the
    fork at 201.62 +- 0.50 px hold the child's bark (the child leaves towards the camera, 0.25 px of
    disparity per px), the outline 199.04, truth 198.85: -12 mm. (Reads of 5 patches within 0.06 px,
    seed 478's fork 10, 2.1 px from their outline, are right.)"""
    return d_outline is not None and not child_confirms and read_mad_px > READ_SCATTER_PX \
        and abs(d_outline - d_fork) > READ_OUTLINE_PX


# a flat parent side carried past its span (not read next to the fork) that differs from the other side, read
# there, by more than CARRIED_APART_PX while the child's curve and its right outline both confirm the read side
# (within CARRIED_CONFIRM_PX each)
CARRIED_APART_PX = 0.5
CARRIED_CONFIRM_PX = 0.5


def carried_side_outvoted(d_read: float, d_carried: float, d_child: float, d_outline: float) -> bool:
    """Whether a flat parent's two sides at a fork disagree because the one carried there is off: the side read
    next to the fork (its bark texture, ``d_read``, px) and the side carried to it past its fitted span
    (``d_carried``) differ by more than ``CARRIED_APART_PX``, while the child's curve ``d_child`` and the child's
    outline in the right view ``d_outline`` both lie within ``CARRIED_CONFIRM_PX`` of the read side: three
    readings at the fork agree, the fourth is a line carried across a gap. Seed 556's fork 10 (exact masks): a
    thick side (r 12.7 px) read next to the fork at 164.91 px, a thin one (r 5.5 px, fitted on 112 columns)
    carried 54 px to 166.25, the child 164.80, the outline 164.85, truth 164.66: their mean +0.92 px, -6.0 mm."""
    return abs(d_read - d_carried) > CARRIED_APART_PX and abs(d_child - d_read) <= CARRIED_CONFIRM_PX \
        and abs(d_outline - d_read) <= CARRIED_CONFIRM_PX


def lone_carried_median(d_side: float, d_child: float, d_outline: float) -> float:
    """The disparity (px) of a fork whose lone flat parent side is only carried to it: the median of that side's
    curve carried past its fitted span ``d_side``, the child's curve ``d_child`` and the child's outline in the
    right view ``d_outline`` (three independent readings at the fork, none of them measured on the parent there;
    the median leaves out the one furthest off on either side). On seeds 100-155 and 356-611, both mask sources,
    such sides (carried 34-60 px) read their forks +0.28 px high at the median (seed 515's fork 16: +0.36 /
    +0.43 px, the child +0.19 / +0.07; seed 511's fork 12: +0.29 / +0.30, the child +0.26 / -0.08, its outline
    -1.30 / +0.16): docs/localize-forktail22.md."""
    return float(sorted((d_side, d_child, d_outline))[1])


# a flat parent whose two sides clearly disagree at a fork (the median of three taken), neither read next to it,
# rests on the child's curve and the child's outline in the right view: they must agree within this (px)
UNREAD_AGREE_PX = 1.0


def child_outline_consensus(d_child: float, d_outline: float | None) -> float | None:
    """The disparity (px) of a fork on a flat parent whose two sides clearly disagree there and neither was read
    next to it (each a curve carried to the fork: a flat piece too short or too curved for a texture line is a
    constant, which on a parent turning in depth is off by the turn times its carry): the mean of the child's
    curve ``d_child`` and the child's outline in the right view ``d_outline`` where those two independent readings
    agree within ``UNREAD_AGREE_PX``; None (the fork is withheld) where they do not, or ``d_outline`` is None
    (:meth:`forkends.ForkPlacing.fork` asks only where the outline was read; without it the median stands). Seed
    607's fork 7 (exact masks): sides 141.36 and 151.70 px (constants of 83 and 95 columns carried 24 and 17 px
    on a parent turning 0.1 px per px), the child a 9-row fit carried 24 rows 146.29, the outline 148.30, truth
    148.07: the median of three took the child, +14.5 mm; colour masks: the child 147.61, the outline 148.14,
    their mean 147.88."""
    if d_outline is None or abs(d_child - d_outline) > UNREAD_AGREE_PX:
        return None
    return 0.5 * (d_child + d_outline)


def few_patch_constant(by_row: bool, n_coef: int, n_samples: int) -> bool:
    """Whether a piece's disparity is a flat piece's constant from at most ``flatfit.FEW_PATCHES`` texture
    patches (``by_row`` False, its disparity polynomial of ``n_coef`` 1 coefficient, ``n_samples`` patches on it;
    0: a constant taken from the forks at its ends): such a constant may scatter 2.3 px (``flatfit.MAX_FEW_MAD_PX``)
    and says nothing of a turn in depth along the piece, so it does not give a hidden fork its disparity
    (``forkends.HIDDEN_ON_FEW_PATCHES``). Seed 607's fork 9 (exact masks): a hidden end carried 20 px onto a
    25-column flat piece's constant from 5 patches, 1.17 px low, +9.3 mm; on every set measured the one other
    hidden fork onto such a piece is false (seed 588, 78 px from any true fork)."""
    return not by_row and n_coef == 1 and n_samples <= FEW_PATCHES


# a lone steep parent side fitted on fewer rows than this, not read next to its fork, is not confirmed there by a child
# curve carried to the fork across more than this many px of disparity (its end slope times the carry)
SHORT_SIDE_ROWS = 20.0
CARRIED_ACROSS_PX = 1.0


def short_side_unconfirmed(side_range: tuple[float, float], d_child: float, d_child_end: float) -> bool:
    """Whether a fork's lone steep parent side, not read from its own crossings next to the fork, is too short to
    stand on a child's curve carried there: the side fitted on ``side_range`` (lo, hi rows) spans fewer than
    ``SHORT_SIDE_ROWS`` rows (a few rows' crossings, often a sliver between occluders, read by single edges),
    and the child's curve is carried to the fork (``d_child``, px) across more than ``CARRIED_ACROSS_PX`` from
    its value at its fitted span's end (``d_child_end``): the carry's own uncertainty is a fraction of that, and a
    short side's of a px. Seed 650's fork 3 (both mask sources): the trunk's side a 16 (11)-row sliver between
    a nearer branch crossing it and the fork, 1 px low; the child's 19 (24)-row fit carried 63 rows across 8.4
    (5.1) px, 3.4 px from the side (0.8: the right outline or the child agreeing); +6.1 / +6.5 mm. A short side
    confirmed by a child carried as far along a flat line stands (seed 508's fork 3: a 10-row side, the child
    carried 41 rows across 0 px, right within 0.3 px)."""
    lo, hi = side_range
    return hi - lo < SHORT_SIDE_ROWS and abs(d_child - d_child_end) > CARRIED_ACROSS_PX


# a flat parent side fitted on fewer columns than this, carried past half its span to the fork and turning in depth
# there faster than forkdisp.FLAT_NEAR_MAX_SLOPE (px of disparity per px), is no reading of the fork's disparity
SHORT_FLAT_COLS = 12.0


def short_turning_flat_side(t_range: tuple[float, float], t_fork: float, turning: bool) -> bool:
    """Whether a flat parent side fitted on ``t_range`` (lo, hi columns) and carried to the fork's column
    ``t_fork`` (px) is no reading of the fork's disparity: fitted on fewer than ``SHORT_FLAT_COLS`` columns,
    carried past half that span (:func:`vouched_by_span` False) and ``turning`` in depth at the fork
    (:func:`forkdisp.turns_in_depth`: its end slope carried, as its texture is not read there). Such a side does
    not enter the mean of the fork's two parent sides (:meth:`forkends.ForkPlacing.fork`, ``SHORT_FLAT_OUT``).
    Seed 772's fork T9 (colour masks): a side fitted on 7 columns with a disparity slope of 1.24 px per px,
    carried 10.7 px, 1.79 px low; the steep side -0.68 px; their mean -1.24 px (+6.1 mm)."""
    lo, hi = t_range
    return hi - lo < SHORT_FLAT_COLS and not vouched_by_span(t_range, t_fork) and turning
