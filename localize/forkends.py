"""Forks placed on the fitted branch curves (:class:`ForkPlacing`, a part of :class:`ends.EndPlacer`).

A fork is where the child's centre line meets the parent's axis, with the parent's disparity there
(its sides' own crossings or bark texture next to the crotch), and is reported only if the child's
own disparity agrees (else two branches merely cross in the image). A hidden end whose centre line
runs on into a thicker piece at the same disparity is a fork too (:meth:`ForkPlacing.hidden_fork`).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from appliance.localize import kernels_forkglue, kernels_forknear, kernels_forks, kernels_walks
from appliance.localize.centreaxis import centre_bias_px
from appliance.localize.curves import BranchCurve, Poly, linspace
from appliance.localize.forkalong import along_fork
from appliance.localize.forkbark import steep_side_bark
from appliance.localize.forkchild import child_texture_agrees, child_texture_elsewhere, passes_through
from appliance.localize.forkcross import crossing_in_front, front_step_px
from appliance.localize.forkdisp import (THROUGH_SHORT_PX, SideNear, bent_sides_apply, flat_near_offset,
                                         flat_side_near, side_disparity_near, side_through_fork, taper_radius,
                                         turns_in_depth, weigh_bent_sides, weigh_sides)
from appliance.localize.forkhidden import crotch_half_px, hidden_parent_disparity, hidden_side_reads
from appliance.localize.forkplace import parent_axis
from appliance.localize.forkoutline import shallow_outline_agrees
from appliance.localize.forkvouch import (carried_side_outvoted, child_outline_consensus, few_patch_constant,
                                          known_side_stands, lone_carried_median, none_vouched, outvoted,
                                          scattered_read_contradicted, short_side_unconfirmed, short_turning_flat_side,
                                          vouched_by_span)
from appliance.localize.graph import JUNCTION

# a hidden end's centre line meeting a piece at less than this is that branch running on behind
# the occluder (bent), not a child meeting its parent
HIDDEN_FORK_MIN_DEG = 20.0
# ... and a piece whose disparity is a flat constant from a few texture patches (forkvouch.few_patch_constant) is
# not a hidden fork's parent (seed 607's fork 9, exact masks: a 5-patch constant 1.17 px off, +9.3 mm)
HIDDEN_ON_FEW_PATCHES = True
# a hidden fork is placed with its parent's disparity read from its own row crossings on each side of the crotch, clear of it
# (forkhidden.py, as ForkPlacing.fork's sides: forkdisp.side_disparity_near), not its fitted curve at the crossing,
# which bends into the crotch's rows at a span's end (docs/localize-softfork25.md: fixture 00 T11 with soft masks,
# +1.61 px); the child's disparity is checked against that read (against the curve instead: the same on the twelve
# sets and the soft 60 scenes, docs/localize-forkread26.md)
HIDDEN_SIDE_READ = True

# the right view's outline of a child must tell its disparity from the parent's to this (px)
OUTLINE_MAX_D_PX = 4.0
# ... and where the child leaves the parent at a shallow angle (its place along the parent in each view
# then off by 1 / sin of its line's error), the two views' places are compared in disparity, not in px
# of place (forkoutline.shallow_outline_agrees)
OUTLINE_SHALLOW = True

# a child without a curve within this of the rows (sine; the matcher's 20 deg of flat pieces) shows
# its depth by its bark texture only: checked there (forkchild.child_texture_agrees)
FLAT_CHILD_SIN = math.sin(math.radians(20.0))

# a flat parent side at a fork takes its disparity from its bark texture next to the fork
# (forkdisp.flat_side_near) where that moves its curve's by more than this (px)
FLAT_NEAR = True
FLAT_NEAR_MIN_PX = 0.25

# ... with the parent's radius at the fork between its two sides' (a tapering branch: ForkPlacing._radius_at_fork)
FLAT_TAPER = True
# ... and for a lone fitted side, between its own and the other side's radius measured next to the fork
# (the distance transform; seed 308's fork: the side's span 15.9 px, the fork 22 px, its texture +1.0 px)
LONE_TAPER = True
LONE_MAX_TAPER = 0.03      # ... if the two radii differ by at most this per px between them (a branch's taper)

# the most (px) the child's right outline may move a flat parent's fork off its texture's disparity: 3 px took
# 2.3 px outlines (seed 328's fork, colour masks: texture -0.5 px, outline -2.8, +27 mm; seed 345's, exact
# masks: +0.45 -> -1.9 px, +5 mm); none of the 60 scenes' or seeds 260-323's forks moved 2-3 px by it
OUTLINE_MAX_SHIFT_PX = 2.0
# ... nor where the parent's bark texture read next to the fork (forkdisp.flat_side_near) confirmed its side's curve
# (within FLAT_NEAR_MIN_PX: the curve stands, read twice) or was taken over it (moving it by more: the fork's own
# measurement, which the outline, its place ~1 px off in each view, confirms but does not move)
# (seed 600's fork 14, colour masks: a lone flat side fitted up to 3.4 px from the fork, read there within 0.25 px
# of its curve, -0.16 px; the outline 1.06 px off moved the fork to +0.90 px, -4.9 mm)
OUTLINE_NOT_OVER_CONFIRMED = True

# a fork whose two steep parent sides differ by more than this (px; less than the clear
# disagreement's 2 px) takes their mean weighted by how well each side's line is known there
# (forkdisp.weigh_sides) instead of the plain mean
SIDES_WEIGHTED = True
SIDES_WEIGHT_PX = 0.5
# ... and any two steep parent sides, each read on enough of its own rows or fitted on a long enough span
# (forkdisp.bent_sides_apply), are weighted by how far each is carried to the fork (forkdisp.weigh_bent_sides:
# the parent bends in depth between a side's rows and the fork), their rows' noise counted where they differ by
# more than SIDES_WEIGHT_PX (docs/localize-forkcurve25.md)
SIDES_BENT = True

# a fork whose two steep parent sides are both known there from their own rows (their fitted spans
# reach it, or forkdisp.side_disparity_near read rows next to it) yet are not of one branch there
# (_agree) is withheld: one side's crossings next to the fork are not the parent's alone in one view
# (a one-sided occluder trimming its outline, the crotch widening it) and nothing tells which (seed
# 273's fork: +3.3 and +1.6 px, the weighted mean +2.9 px, 17 mm)
SIDES_CONFLICT_WITHHELD = True
SIDE_KNOWN_PX = 12.0                # (a side read from its own rows: the nearest this close to the fork)
# ... and so is a fork whose one steep parent side is carried past what its span vouches for (_reach > 0),
# its own rows next to the fork not read, with no child curve to confirm it (seed 264's fork, colour
# masks: one side carried 53 rows, +0.6 px; read from its rows with the exact masks, +0.2)
LONE_SIDE_WITHHELD = True
# ... and so is a fork whose lone steep parent side is read from its own crossings further than LONE_FAR_PX
# (px) from the fork, its only confirmation a child curve carried further than that too: two lines carried
# across the same gap agree where both were read, not at the fork (seed 333's fork, exact masks: the side read
# 82 rows off, 141.03 px, the child carried 86 rows, 140.74, agreeing; truth 142.09, +9.2 mm)
LONE_FAR_WITHHELD = True
LONE_FAR_PX = 40.0
# ... and so is a fork whose lone steep parent side, not read next to it, is carried further than LONE_FAR_PX, its
# only confirmation a child curve carried further than that too (seed 630's fork 3, exact masks: a trunk side carried
# 75 rows past its 245, 174.80 px, the child's 8-row fit carried 47 rows, 174.67, agreeing; truth 172.88, -11 mm),
# or is fitted on a few rows, its only confirmation a child curve carried across a px of disparity or more
# (forkvouch.short_side_unconfirmed: seed 650's fork 3, both mask sources, a 16-row side 1 px low, +6.1 / +6.5 mm)
LONE_FAR_UNREAD_WITHHELD = True
# ... and so is a fork whose lone steep parent side, not read next to it, is carried further than CHILD_CARRY_PX (rows)
# where the side's bark texture next to the fork (forkbark.steep_side_bark) reads more than LONE_BARK_PX from the
# fork's disparity (seed 657's fork 7, exact masks: a 94-row side whose fit curls at its end carried 16.5 rows to
# 147.70 px, its bark 149.13, truth 149.17: +11.8 mm)
LONE_BARK_WITHHELD = True
LONE_BARK_PX = 1.0
# ... and so is a fork whose lone steep parent side, read from its own crossings, differs from the fork's
# disparity (taken from the child's curve carried to it: _known_disparity) by more than LONE_READ_PX: the two
# lines disagree and neither is known at the fork (seed 450 T1, exact masks: the side read 44 rows off at
# 175.41 px, the child carried 39 rows at 173.97, truth 175.07: +6.3 mm)
LONE_READ_WITHHELD = True
LONE_READ_PX = 1.0

# a flat parent whose two read sides differ at the fork by more than this (px) takes the mean of
# the two and the child's right outline's disparity (if within the outline check's tolerance of
# the nearer side); the outline within 1 px of the parent's confirms the fork
FLAT_PICK = True
FLAT_SIDES_DIFFER_PX = 0.5
# ... but two sides more than this apart (px) where the outline lies within 1 px of one and the child's curve
# agrees with that one (_agree) take that side and the outline only: the other is off (seed 359's fork,
# colour masks: a 66 px side, a constant (flat pieces under 100 px) where the branch turns 3 px in depth along
# it, carried 33 px to +3.0, its texture searched about that; the other side +0.7, the outline -0.05, the
# child +0.1; the mean of three +1.2 px)
FLAT_PICK_ONE = True
FLAT_PICK_APART_PX = 1.5

# a flat parent whose two sides disagree at a fork, the child's curve carried further than this to
# it (px), takes the side its child's right outline agrees with (within this, px) and the outline
CHILD_CARRY_PX = 12.0
SIDE_OUTLINE_PX = 0.5

# a stub's curve (caps.py) gained after its fork was placed from its right outline, further than this
# from the flat parent's disparity at its end next to the fork (px), discredits that outline
CHILD_DEPTH_PX = 6.0

# a parent side carried past half its fitted span, known at the fork only by _reach's 12 px floor (a fit on a
# few rows), does not replace the fork's disparity in _known_disparity (forkvouch.py: seed 512's fork 9, exact
# masks, a 13-row side carried 9.5 rows, 4.15 px off, over the median of three, 0.7 px)
SHORT_SIDE_NOT_KNOWN = True
# ... nor is such a side known there against the other side read from its own crossings or texture next to the fork:
# the read side alone is (seed 772 T9, exact masks: a flat side fitted on 7 columns carried 11, 5.3 px low, the
# steep side read 3 rows from the fork +0.03 px; both counted as known, the median of three took the child carried
# 41 px, -0.87 px, +4.3 mm)
FLOOR_SIDE_UNKNOWN_BY_READ = True
# a flat parent side fitted on fewer than forkvouch.SHORT_FLAT_COLS columns, carried past half its span to the fork
# and turning in depth there (forkdisp.turns_in_depth), its texture not read, leaves the mean of the two sides: the
# other side alone (seed 772 T9, colour masks: a 7-column side, 1.24 px per px, carried 10.7 px, -1.79 px)
SHORT_FLAT_OUT = True
# ... and a fork whose two steep sides clearly disagree (the median of three taken) is withheld where none of the
# three pieces is known at it by its own span and no side was read next to it (forkvouch.none_vouched: seed 512's
# fork 9, both mask sources, -3.7 mm after the rule above)
NONE_KNOWN_WITHHELD = True
# ... and so is a fork whose two steep sides clearly disagree (the median of three taken) where the child's curve
# clearly disagrees with both too (as the sides: beyond 2 px or 1.2 %): no two of the three readings agree, whichever
# is read next to the fork (seed 639's fork 11, exact masks: one side read 34 rows off at 139.09 px, the other
# another branch at 496, the child carried 49 rows at 143.84; the fork took the read side, truth 136.96: +19 mm;
# within _agree's 1 px the rule lost seed 100's fork 3, exact masks: the read side right, the child 1.17 px from it)
STEEP_NONE_AGREE_WITHHELD = True
# a lone flat parent side's disparity at a fork that the child's curve and the child's right outline both contradict
# (agreeing with each other: forkvouch.outvoted) gives way to the mean of the three (seed 378's fork 11, exact masks:
# the side's texture fit 0.78 px low along its whole length, +6.9 mm)
LONE_FLAT_OUTVOTED = True
# a fork whose lone flat side's texture read next to it is scattered and 2+ px from the child's right outline is
# withheld (forkvouch.scattered_read_contradicted: seed 528's fork 14, colour masks, -12 mm)
SCATTERED_READ_WITHHELD = True
# ... and, where forkdisp.FLAT_NEAR_SHIFT moved the side's patches onto the fork, the same check is run on the read of
# the unmoved patches too (seed 528's fork 14, colour masks: the moved read no longer withheld, -6.86 mm)
FLAT_NEAR_SHIFT_UNMOVED = True
# ... and the patches are moved only for a side whose unmoved patches were read: a side not read next to the fork stays
# carried (seed 556's fork 10, exact masks: a thin side carried 54 px, unread, moved read +0.31 px, so the fork took the
# sides' mean +0.28 px in place of CARRIED_FLAT_OUTVOTED's mean of three +0.20: -1.27 -> -1.84 mm, 548 p95 1.77 -> 1.81)
FLAT_NEAR_SHIFT_READ = True
# a lone flat side whose own fit reaches the fork (carried at most 1 px past its span: measured there, not read
# again) is neither out-voted nor moved by the child's right outline (seed 540's fork 14, exact masks: a side fitted
# on 144 columns up to the fork, 0.17 px off; the child carried 27 rows and its outline, 1.3 / 1.8 px off, agreeing
# with each other: their mean with it +9.1 mm)
REACHED_STANDS = True
# a flat parent's side carried to the fork further than CHILD_CARRY_PX past its span, not read there, gives way to
# the other side read next to the fork where the child's curve and the child's right outline both confirm the read
# side: the fork takes the mean of those three (forkvouch.carried_side_outvoted: seed 556's fork 10, exact masks,
# a thin side carried 54 px, 1.6 px off; the plain mean of the sides -6.0 mm)
CARRIED_FLAT_OUTVOTED = True
# a flat parent whose two sides clearly disagree at a fork (the median of three taken), neither of which was read
# next to it nor agrees with the child's curve (_agree), takes the mean of the child's curve and the child's right
# outline where those agree, else the fork is withheld (forkvouch.child_outline_consensus: seed 607's fork 7, exact
# masks, two constant sides 10 px apart on a parent turning in depth, the median the child's 9-row fit carried 24
# rows, +14.5 mm; a side that agrees with the child stands: seed 364's fork 14, exact masks, one side another
# branch 63 px off, the other 0.35 px from the child, the outline 1.6 px from both, right at -1.0 mm)
UNREAD_SIDES_APART = True

# a fork whose disparity is a lone flat parent side's curve carried further than CHILD_CARRY_PX past its fitted span
# (not read next to the fork, or its texture there within FLAT_NEAR_MIN_PX of the curve) takes the median of that
# side, the child's curve and the child's right outline (forkvouch.lone_carried_median); after every decision, so
# which forks are reported is unchanged (docs/localize-forktail22.md: such forks read +0.28 px high at the median)
LONE_CARRIED_MEDIAN = True
# ... and so does such a fork whose disparity _known_disparity took from the child's curve, itself carried further
# than CHILD_CARRY_PX and past half its span (the one carried least far, no piece known at the fork by its span):
# two lines carried across gaps, the outline the third reading (seed 825 T12, exact masks: the parent's 19-column
# constant carried 39 px, +0.71 px, the child's 32-row fit carried 25 rows, -0.72, the outline +0.35; the child's
# +6.8 mm, the median -3.3 mm)
CARRIED_CHILD_MEDIAN = True
# fresh31 (docs/localize-fresh31.md): a fork whose disparity is still a lone flat parent side's curve carried further
# than CHILD_CARRY_PX past its fitted span (not read next to the fork), which the child's right outline contradicts by
# more than OUTLINE_MAX_SHIFT_PX (too far to move it: the rule above) and no child's curve confirms, is withheld: no
# reading of the fork's own stands. Seed 1093 T5, exact masks: the side carried 48 px at -2.60 px, the outline +1.05
# px, no child curve; +18.56 mm. On 1092-1123 and the 60 scenes the other such forks' outlines lie within 0.7 px.
LONE_CARRIED_CONTRADICTED_WITHHELD = True

# the child's fit vouches in _known_disparity (taken over the parent's sides) for at most this far (px)
# past its span, not half its span (60-110 px for a long one: seed 362's fork took its child's flat curve
# carried 68 px, +1.1 px, over the parent read from its own rows, right; docs/localize-forkd.md: curves
# carried 60+ rows are off by 1.6 px at p90). (Capping the sides' too lost seed 364's fork, exact masks:
# one side another branch 63 px off, the other carried 49 px of its 109, the median of three right.)
KNOWN_VOUCH_CAPPED = True
KNOWN_VOUCH_MAX_PX = 60.0
# ... and a child's curve carried past its fitted span, known at the fork only by what its span vouches for (_reach's
# 12 px floor, or half its span), does not replace a steep parent side read from its own crossings whose nearest row
# lies within READ_OVER_CHILD_PX of the fork (known there itself but for the 12 px bound): the parent's own rows
# against the child's end slope carried into the crotch, where a child may bend at the parent's outline
# (docs/localize-forkoff30.md). Seed 1080 T13, exact masks: the lone side read 12.7 px from the fork, -0.03 px; the
# child's 25-row fit carried 11.3 rows, -0.86 px (its own rows next to the fork -0.60), taken: +6.86 mm, now +0.26;
# seed 1047 T7: the side read 15 / 17 px off, -0.05 / -0.16 px, the child carried 36-37 px, -0.57 / -0.49: +2.30 /
# +1.97 mm, now +0.21 / +0.64; seed 542 T5 (exact) the other way, 0.09 px: a side read 21 px off +0.11, the child
# carried 45 px +0.02, -0.15 -> -0.93 mm (docs/localize-gross31.md)
READ_OVER_FLOOR_CHILD = True
READ_OVER_CHILD_PX = 24.0

# a flat side's texture read next to the fork (forkdisp.flat_side_near) makes it known there in
# _known_disparity, as a steep side's own crossings do, only if its patches agree (scaled MAD within this,
# px): it is searched within 3 px of the side's curve carried to the fork, and where that curve is off the
# bark's match lies at the search's edge or beyond, the patches scattered (seed 364's fork, colour masks: a
# 26 px flat side carried 32 px, -2.7 px, its 3 patches 12-24 px off -2.7 px too, MAD 0.51, "known"; the
# steep side, 2 rows past its span, +0.4 px; the median of three took the child carried 34 rows, -0.9 px;
# seed 368's, exact masks: 5 patches from the fork, MAD 0.03, -0.1 px, known)
FLAT_READ_VOUCHES = False
FLAT_READ_VOUCH_MAD_PX = 0.25

# a fork placed from the child's outline is placed again against the parent's axis from its own
# cross-sections clear of the crotch (forkplace.parent_axis)
PARENT_FROM_SECTIONS = True
SECTIONS_MIN_MOVE_PX = 1.5          # (closer, the first place stands: the two agree within their noise)

# a fork on steep parent sides (their disparities the middles of row crossings) is moved onto the parent's
# axis: a thick branch's crossings' middles lie (d - offset) (r / f)^2 / (1 + x^2) px further apart than its
# axis (centreaxis.centre_bias_px; +0.04 px at the median of the forks of seeds 100-155 and 260-483, as
# predicted by radius); after every decision (which forks are reported is unchanged), where each side is known
# there from its own crossings (_steep_known: a side carried further is off by its carry, 0.3-1.5 px, not by this)
CENTRE_TO_AXIS = True
CENTRE_MAX_RADIUS_PX = 30.0         # ... for a parent up to this radius (px; thicker ones, the scenes' trunks, read
                                    # 0.07 px where 0.10 is predicted: over-corrected, their cause not traced)

# a fork whose child has no curve is withheld where the child's bark texture just past the parent's outline matches
# clearly at another depth (forkchild.child_texture_elsewhere: seed 642's fork 7, exact masks, the child leaving a
# thinner branch hidden beside the parent in the image 12 px behind it; its right outline agreed with the parent's
# disparity by chance: -59 mm)
CHILD_ELSEWHERE_WITHHELD = True
# a fork with no child outline next to the parent (a child lying along its parent: the junction 40-130 px past the
# fork) is placed from the merged silhouette's widening (forkalong.along_fork) where that is clear; its parent's
# sides read from their own crossings and weighed by their carry as any fork's (side_disparity_near,
# weigh_bent_sides: seed 616's fork 1, colour masks, +0.42 px from its parent's curves at stop 25, +0.30 px now).
# The twelve sets gain 4 forks and no false one, every p95 and max as before or better (612-643 colour 2.29 ->
# 2.27 mm): docs/localize-forkalong25.md, docs/localize-forkread26.md
ALONG_FORK = True
ALONG_OVER_OUTLINE = False      # (... also over a place from the child's outline: measured, not kept)
# ... and confirmed, where nothing else confirms its child, by the same construction in the right view placing it
# at the left place moved by the fork's disparity, within this (px) or 0.9 % of the disparity
ALONG_RIGHT = True
ALONG_RIGHT_PX = 2.0
# ... and it confirms a child not confirmed otherwise at a place from the child's outline within ALONG_NEAR_PX of its
# own. Off: +1 fork on each of 60 exact / colour, 356, 452, 484 exact, but 60 exact max 3.12 -> 3.61 mm, p95 1.90 ->
# 1.92, 484 exact one false fork more (docs/localize-forkalong25.md)
ALONG_CONFIRMS = False
ALONG_NEAR_PX = 4.0

# a fork that took its lone steep parent side's value (the other parent piece without a curve through the fork), the
# side read more than forkdisp.THROUGH_SHORT_PX short of the fork or carried there unread, takes the side read again
# with the parent's crossings past the fork as far as the other piece runs on (forkdisp.side_through_fork): the fork
# between the line's rows, not past them (seed 620 T1, exact masks: a trunk side read 33 rows short, +0.63 px,
# -4.6 mm; -0.17 px read through it). After every decision (which forks fork() reports is unchanged); the feature check
# then withholds one correct fork of the fifteen sets (seed 751 T5, colour masks; docs/localize-forkp27.md)
THROUGH_FORK = True
THROUGH_MAX_MOVE_PX = 1.0       # (... moving the side's value by at most this, px: further, the rows past the fork are
                                # another branch's; seed 119's fork, exact masks, a 5-row side moved 1.8 px)
# a fork whose parent pieces run straight through the node with like radius and whose child is several times thinner,
# the child's own curve at the node in front of the parent by about the parent's front-surface step (d r / f), is a
# thin branch crossing in front of the parent, meeting it at its front surface, not at its axis
# (forkcross.crossing_in_front: seed 910 T10, exact +20.19 mm, colour +19.09, at the trunk's axis; seed 132's false
# fork, a thin branch's end over a trunk; docs/localize-cross28.md). Placed there, at the thicker side's front surface
# d (1 + r / f), after every decision (910 T10: -0.38 / -1.49 mm; seed 132's is then withheld by the feature check,
# its trunk pieces reading 5.2 px behind it) ...
CROSSING_IN_FRONT = True
# ... or, with this off, withheld (measured: 910 T10 withheld, 900-931 recall 0.600 -> 0.596 / 0.592 -> 0.588)
CROSSING_IN_FRONT_PLACED = True

# a fork on a flat parent (a side of it flat: its disparity from bark texture, ~0.2 px rms at 750-1500 mm) with a
# steep child whose own row crossings, read as a parent side's (forkdisp.side_disparity_near), come within
# FLAT_CHILD_READ_PX of the fork takes the mean of its disparity and that read: the child's rows clear of a flat
# parent are at the fork's depth a few px from it (13 sets, 750-1500 mm, both masks: 59 such forks, rms 0.224 ->
# 0.136 px, p95 0.448 -> 0.253 on paper; seed 378 T11, colour masks, -0.74 px, +6.6 mm -> +1.4 mm). Reads 10-12 px
# off count no more (104 forks to 12 px: rms 0.218 -> 0.172; seed 458 T11 read 12 px off, +0.71 px, -1.6 -> -3.0 mm).
# After every decision, as THROUGH_FORK. Off: on the fifteen sets it moves some forks the other way (484-515 exact
# 1000-1250 mm 1.55 -> 1.66, 548-579 exact p95 1.77 -> 1.83) and the feature check then passes a fork 5.8 mm off
# (676-707 colour max 2.20 -> 5.84), against 356-387 colour max 6.58 -> 3.16, 452-483 exact 4.22 -> 3.68
# (docs/localize-forkp27.md)
FLAT_CHILD_READ = False
FLAT_CHILD_READ_PX = 10.0
# ... on for a fork whose parent is a lone flat side carried a few px past its span to the fork (at most
# CHILD_CARRY_PX; further: LONE_CARRIED_MEDIAN's case), its texture next to the fork agreeing with its curve
# (forkdisp.flat_side_near within FLAT_NEAR_MIN_PX): the fork's one reading is that side's level carried, and a
# child read within LONE_FLAT_CHILD_READ_PX is a second, independent one: their mean (seeds 981 T10 and 972 T14
# of 964-995, both mask sources: the side 0.34-0.42 px far, the child read within 0.12 px; docs/localize-gross29.md)
LONE_FLAT_CHILD_READ = True
LONE_FLAT_CHILD_READ_PX = 15.0
# ... and so for such a side taken by the median of three (the parent's two sides clearly apart, the other one off):
# the fork's one reading is again that side's level carried a few px, the child's rows the second (seed 1089 T16:
# a 36-column flat side carried 7-9 px, its texture agreeing, +0.60 / +0.68 px, the other side's 26-column
# constant carried 33 px, +3.1; the child read 6-8 px from the fork -0.54 / -0.37 px: -2.76 / -3.09 mm,
# docs/localize-gross31.md)
MEDIAN_FLAT_CHILD_READ = True
# a fork whose skeleton junction is split in two, joined by a one-point piece (each junction then has fewer than
# three usable pieces and placed nothing): the pair's pieces together, from the pair's middle (docs/localize-forks29.md:
# unchecked, on the twenty sets +10 forks, +7 false ones and a fork 69 mm off, 615 T10 colour) ...
SPLIT_JUNCTION = True
SPLIT_PIECES = 3                # ... a Y: the pair's pieces three (four: a crossing, or a fork beside one: measured)
# ... only where the child's outline places it alike taken from either node of the pair (within SPLIT_AGREE_PX px),
# at those places' mean, and no piece of another branch lies within SPLIT_CLEAR_PX px of its own radius of that place
# (615 T10: a branch crossing the fork, its disparity taken; 940 T9, 898, 874: the two nodes' places 17-125 px
# apart) (docs/localize-split29.md)
SPLIT_CHECKED = True
SPLIT_AGREE_PX = 4.0
SPLIT_CLEAR_PX = 10.0
# ... and one node of the pair at least SPLIT_OFF_AXIS parent radii off the parent's line (the child's side of the split
# lies near the parent's outline: 1.0-1.5 radii on seeds 132, 138, 153, 1006, 1018; 0.5 on 643 T5, a thick parent's
# pair deep inside it, placed 19 px back along the parent)
SPLIT_OFF_AXIS = 0.8


def _parent_pair(segs: list, rad: dict, dirs: dict) -> tuple[int, int]:
    """The two parent pieces of a junction's ``segs``: of three, the two others where one is under 0.8 of their
    thinner's radius (``rad``, px); otherwise the two whose directions from the junction (``dirs``) are most
    nearly opposite."""
    thin = min(segs, key=rad.get)
    rest = [s for s in segs if s != thin]
    if len(segs) == 3 and rad[thin] < 0.8 * min(rad[s] for s in rest):
        return rest[0], rest[1]
    _, pa, pb = min((np.dot(dirs[a], dirs[b]), a, b) for i, a in enumerate(segs) for b in segs[i + 1:])
    return pa, pb


def _line(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Total-least-squares line through points (N, 2): centroid and unit direction (the direction of
    the largest spread; compiled: :func:`kernels_forks.tls_line`)."""
    return kernels_forks.tls_line(np.ascontiguousarray(pts, float))


def _intersect(c1, e1, c2, e2) -> np.ndarray | None:
    """Intersection of the lines c1 + t e1 and c2 + s e2; None when (nearly) parallel."""
    e1x, e1y, e2x, e2y = float(e1[0]), float(e1[1]), float(e2[0]), float(e2[1])
    det = e2x * e1y - e1x * e2y           # (the 2 x 2 system [e1, -e2] t = c2 - c1 by Cramer's rule: as
    if abs(det) < 0.05:                    # LAPACK's det and solve up to rounding)
        return None
    bx, by = float(c2[0] - c1[0]), float(c2[1] - c1[1])
    return c1 + ((e2x * by - bx * e2y) / det) * e1


def _t_at(c: BranchCurve, xy: np.ndarray) -> float:
    """``c.t_of(xy)[0]`` of one point ``xy`` (2,) as a Python float (the curves' one-point path)."""
    return float(xy[1] if c.by_row else xy[0])


def _d_at(c: BranchCurve, xu: float, xv: float) -> np.float64:
    """``c.d_at(_t_at(c, xy))[0]`` at the point (``xu``, ``xv``) px: the curve's one-point path
    (:meth:`BranchCurve._at` with its end slopes), without the one-element array."""
    return np.float64(c._at(c.d_poly, xv if c.by_row else xu, c.d_end_slopes))


def walk_reach_t(c: BranchCurve, t_edge: float, sign: float, reach_px: float) -> float:
    """How far in the curve's parameter ``t`` (rows of a steep piece, columns of a flat one) a walk from
    ``t_edge`` in the direction ``sign`` goes to cover ``reach_px`` along the branch in the image: the
    reach divided by the centre line's speed there (|d uv / dt|, px per unit of t, at least 1). A piece
    at 24 deg to its parameter's axis walked ``reach_px`` rows would run 2.4x as far
    (docs/localize-softfork25.md)."""
    step = c.uv_at(np.array([t_edge, t_edge + sign]))
    return reach_px / max(float(np.hypot(*(step[1] - step[0]))), 1.0)


def _agree(d1: float, d2: float) -> bool:
    """Whether two disparities (px) at one point are of one branch: within 1 px or 0.6 %."""
    return abs(d1 - d2) <= max(1.0, 0.006 * abs(d2))



class ForkPlacing:
    """:class:`ends.EndPlacer`'s forks (its state: ``curves``, ``uvd``, ``hidden``, the graph ``g``, the
    masks ``sm``)."""

    def fork(self, node: int, final: bool = False, needed: bool = True) -> None:
        """A fork: where the child's centre line meets the parent's, with the parent's disparity.

        The parent is the pair of pieces that continue each other (most opposite directions;
        the clearly thinnest piece is never a parent). The fork is reported only if the
        child's own disparity there agrees with the parent's: otherwise the pieces merely
        cross in the image (at different depths), and only if the child's outline leaving the
        parent is clear in the left view. Until ``final`` a fork waits for a fitted
        parent. A provisional (not ``final``) place that is not ``needed`` before the final
        round (no piece of the node gains a curve in between) is placed only if the final
        round finds no place, keeping it as placing it first would.
        """
        if not final and not needed:
            self._deferred.add(node)
            return
        segs = [s for s in self.incident[node] if self._usable(s)]
        p, split_xy = self.node_xy[node], None
        if len(segs) < 3 and SPLIT_JUNCTION:
            # a junction split in two by a one-point piece: the pair's pieces together, from the pair's middle
            other = self._split_partner(node)
            if other is not None:
                segs = segs + [s for s in self.incident[other] if self._usable(s) and s not in segs]
                p = 0.5 * (self.node_xy[node] + self.node_xy[other])
                if SPLIT_CHECKED:
                    split_xy = self._split_pair_place(node, other, segs)
                    if split_xy is None:
                        return
        if len(segs) < 3:
            return
        r = self._node_radius(node)
        near, rad, dirs = {}, {}, {}
        for s in segs:                  # (cached: both fork rounds ask)
            c = self.curves.get(s)
            hit = self._near_cache.get((node, s))
            if hit is None or hit[0] is not c:
                hit = self._near_cache[node, s] = (c, *self._near_dir(s, p, r))
            near[s], rad[s], dirs[s] = hit[1], hit[2], hit[3]
        pa, pb = _parent_pair(segs, rad, dirs)
        children = [s for s in segs if s not in (pa, pb)]
        child = max(children, key=lambda s: (s in self.curves, rad[s]))
        parents = [s for s in (pa, pb) if s in self.curves]
        if not parents and not final:
            return
        c1, e1 = kernels_forks.tls_line_pair(near[pa], near[pb])      # (_line of the two, concatenated)
        if child in self.curves:             # the child's own fitted centre line where it starts
            cc = self.curves[child]
            lo, hi = cc.t_range
            tp = _t_at(cc, p)
            t_end = hi if abs(tp - hi) <= abs(tp - lo) else lo
            c2, e2 = _line(self._curve_uv(cc, t_end, t_end + (12.0 if t_end == lo else -12.0), 12))
        else:
            c2, e2 = _line(near[child])
        p0 = c1 + np.dot(p - c1, e1) * e1                # the junction on the parent's line
        r_par = max(rad[pa], rad[pb])
        # the child's outline where it leaves the parent, against the parent's line behind the
        # fork (the parent may bend at the fork) or else through both sides
        behind = min((pa, pb), key=lambda s: np.dot(dirs[s], dirs[child]))
        xy, outline, along = None, None, False
        lines = ([_line(near[behind])] if len(near[behind]) >= 3 else []) + [(c1, e1)] if final else []
        for cl, el in lines:               # (before the final round a rough place will do)
            xy = self._fork_from_child_outline(cl, el, c2, e2, cl + np.dot(p - cl, el) * el, r_par, rad[child])
            if xy is not None:
                outline = (cl, el)
                break
        if outline is not None and PARENT_FROM_SECTIONS:
            # the parent's line near the crotch is pulled towards the child: its axis again from its
            # own cross-sections clear of the crotch on both sides, and the child's outline against it
            ax = parent_axis(self.sm.left_mask, xy, outline[1], e2 if np.dot(c2 - xy, e2) >= 0 else -e2,
                             rad[behind], rad[pb if behind == pa else pa], rad[child])
            xy2 = None if ax is None else self._fork_from_child_outline(
                ax[0], ax[1], c2, e2, ax[0] + np.dot(p - ax[0], ax[1]) * ax[1], r_par, rad[child])
            if xy2 is not None and np.hypot(*(xy2 - xy)) > SECTIONS_MIN_MOVE_PX:     # (within it: noise)
                xy, outline = xy2, ax
        if ALONG_FORK and final and (xy is None or ALONG_OVER_OUTLINE):
            # a child lying along its parent: its outline parts from the parent's tens of px past the fork
            # (where the junction formed); the merged silhouette's widening gives its axis (forkalong.py)
            hit = along_fork(self.sm.left_mask, p0, e1, e2 if np.dot(c2 - p0, e2) >= 0 else -e2, r_par, rad[child])
            if hit is not None:
                xy, outline, along = hit[0], (hit[1], hit[2]), True
        if outline is not None and split_xy is not None:
            xy = split_xy               # (a split junction's pair: the place both its nodes agree on)
        if xy is None:
            # the skeleton junction lies where the child's outline leaves the parent's, ahead of
            # the fork in the child's direction: the fork slides back along the parent further
            # than ahead
            xy = _intersect(c1, e1, c2, e2)
            if xy is None:
                xy = p0
            else:
                ahead = np.sign(np.dot(c2 - p0, e1)) or 1.0
                shift = min(max(ahead * np.dot(xy - p0, e1), -(3.0 * r_par + 2 * self.g.scale)),
                            0.5 * r_par + 2 * self.g.scale)          # (np.clip of one value, without its overhead)
                xy = p0 + ahead * shift * e1
        xu, xv = xy.tolist()
        # (a curve's disparity at xy: d_at's one-point path, BranchCurve._at, as d_at(t)[0]'s float64)
        at = lambda s: _d_at(self.curves[s], xu, xv)

        def passes(s):              # a curve's disparity at the fork's row/column is its own there
            c = self.curves[s]
            t = _t_at(c, xy)
            s_t = c._at(c.s_poly, t)        # (c.uv_at(t)[0] - xy in Python floats: uv_at's one-point path)
            return np.hypot(*((s_t - xu, t - xv) if c.by_row else (t - xu, s_t - xv))) \
                <= max(rad[s], 3.0) + 2 * self.g.scale
        parents = [s for s in parents if passes(s)]
        child_ok = child in self.curves and passes(child)
        # a side whose fit stops short of the fork is read again from its own crossings nearest it
        # (its crossings far from the junction's blob are the parent's alone: forkdisp.py); a fork
        # without the child's outline is withheld whatever its disparity (below): not read
        side_near, flat_read, unmoved = {}, set(), {}
        for s in parents if final and outline is not None else ():
            c = self.curves[s]
            if c.by_row:
                v = side_disparity_near(c, self.runs_l, self.runs_r, _t_at(c, xy), f_px=self.sm.f_px,
                                        cx_px=self.sm.cx_px, offset_px=self.sm.offset_px)
            elif FLAT_NEAR:     # a flat side: its bark texture next to the fork (forkdisp.flat_side_near)
                kw = dict(radius_px=self._radius_at_fork(parents, xy, [t for t in (pa, pb) if t not in parents],
                                                         rad, near) if FLAT_TAPER else None,
                          left_mask=self.sm.left_mask, right_mask=self.sm.right_mask)
                v = flat_side_near(c, self.sm.left_gray, self.sm.right_gray, _t_at(c, xy),
                                   self.sm.f_px, self.sm.offset_px, **kw)
                r_f = c.radius_px if kw['radius_px'] is None else float(kw['radius_px'])
                if flat_near_offset(c, _t_at(c, xy), xy, r_f) is not None and (v is not None or not FLAT_NEAR_SHIFT_READ):
                    # (forkdisp.FLAT_NEAR_SHIFT: the patches moved onto the fork; the unmoved read kept for the
                    # scattered-read check below: FLAT_NEAR_SHIFT_UNMOVED)
                    if v is not None and abs(v.d_px - at(s)) > FLAT_NEAR_MIN_PX:
                        unmoved[s] = v
                    v = flat_side_near(c, self.sm.left_gray, self.sm.right_gray, _t_at(c, xy),
                                       self.sm.f_px, self.sm.offset_px, at_uv=xy, **kw)
                # (within the patches' scatter of the curve, fitted on the whole piece, the curve stands)
                if v is not None:
                    flat_read.add(s)
                    if abs(v.d_px - at(s)) <= FLAT_NEAR_MIN_PX:
                        v = None
            else:
                v = None
            if v is not None:
                side_near[s] = v
        if side_near:
            at_curve = at
            at = lambda s: side_near[s].d_px if s in side_near else at_curve(s)
        # (SHORT_FLAT_OUT: a flat side fitted on a few columns, carried past them and turning in depth is no reading)
        d_par = [at(s) for s in (self._mean_sides(parents, xy, side_near) if SHORT_FLAT_OUT and final else parents)]
        sides = None                    # (the two sides' disparities where they clearly disagree)
        if len(d_par) == 2 and child_ok and abs(d_par[0] - d_par[1]) > max(2.0, 0.012 * abs(d_par[0])):
            # the parent's two sides clearly disagree at the fork (one side's fit is off there):
            # the middle of the three pieces' disparities
            sides = d_par
            d_par = [float(sorted([*d_par, at(child)])[1])]      # (the median of three, as np.median)
        if parents:
            d = float(sum(d_par) / len(d_par))    # (np.mean's sums of one or two values, bit for bit)
        elif child_ok:
            d = float(at(child))
        else:
            if final and node in self._deferred:
                self._deferred.discard(node)
                self.fork(node)                   # the provisional place stands
            elif final:
                self.place_pending(node)          # (if not made yet: it stands)
            return
        agree = seen_right = unread_apart = False
        d_out = None
        if parents and outline is not None and not any(self.curves[s].by_row for s in parents):
            # a flat parent's disparity (from its texture) may be a px or two off; the child's
            # outline leaving it in the right view tells the fork's own (along the rows)
            d_out = self._flat_fork_disparity(xy, outline[1], c2, e2, d, r_par, rad[child])
            # (unless the child's own disparity agrees with the parent's: the two views' outline
            # places may be a px or two apart, as with noisy masks)
            reached = REACHED_STANDS and len(parents) == 1 and parents[0] not in side_near \
                and self._carried_px(parents[0], xy) <= 1.0
            if d_out is None:
                pass
            elif sides is not None and self._carried_px(child, xy) > CHILD_CARRY_PX \
                    and min(abs(v - d_out) for v in sides) <= SIDE_OUTLINE_PX:
                # the median above took the child's curve carried far to the fork (its end slope
                # carried tens of rows): the side that the right outline confirms (seed 151's fork,
                # +2.5 px from the child's carried curve)
                d, agree = 0.5 * (min(sides, key=lambda v: abs(v - d_out)) + d_out), True
            elif UNREAD_SIDES_APART and sides is not None and not any(s in flat_read for s in parents) \
                    and not any(_agree(at(child), v) for v in sides):
                # two sides carried to the fork, clearly apart, neither read there, the child agreeing with
                # neither (the median of three is the child alone): the child's curve and its right outline
                # decide, if they agree (forkvouch.child_outline_consensus: seed 607's fork 7)
                d_cons = child_outline_consensus(float(at(child)), d_out)
                if d_cons is None:
                    unread_apart = True
                else:
                    d, agree = d_cons, True
            elif CARRIED_FLAT_OUTVOTED and sides is None and len(parents) == 2 and child_ok \
                    and sum(s in flat_read for s in parents) == 1 and all(
                        s in flat_read or self._carried_px(s, xy) > CHILD_CARRY_PX for s in parents) \
                    and carried_side_outvoted(*(at(s) for s in sorted(parents, key=lambda s: s not in flat_read)),
                                              at(child), d_out):
                # the side carried far to the fork is off: the side read there, the child's curve and its right
                # outline agree (forkvouch.carried_side_outvoted: seed 556's fork 10)
                d, agree = float((at(next(s for s in parents if s in flat_read)) + at(child) + d_out) / 3.0), True
            elif FLAT_PICK and len(d_par) == 2 and all(s in flat_read for s in parents) \
                    and abs(d_par[0] - d_par[1]) > FLAT_SIDES_DIFFER_PX:
                # the two sides' textures next to the fork disagree: the outline's disparity too, if
                # within the outline check's tolerance of one (each view's outline place is ~1 px off)
                # (picking the nearer side alone was worse: the outline's place is noisy)
                d_one = min(d_par, key=lambda v: abs(v - d_out))
                if FLAT_PICK_ONE and abs(d_par[0] - d_par[1]) > FLAT_PICK_APART_PX and abs(d_one - d_out) <= 1.0 \
                        and child_ok and _agree(at(child), d_one):
                    # sides too far apart for the textures' noise: one is off (a short piece's constant carried
                    # past it anchors its texture's search); the one the outline and the child confirm
                    d, agree = 0.5 * (d_one + d_out), True
                elif min(abs(v - d_out) for v in d_par) <= max(1.6, 0.009 * abs(d)):
                    d, agree = float((d_par[0] + d_par[1] + d_out) / 3.0), True
            elif FLAT_TAPER and len(d_par) == 2 and all(s in flat_read for s in parents):
                # the two sides' textures next to the fork agree: two measurements of the parent there,
                # which the outline (its place ~1 px off in each view) confirms, as within the 3 px the
                # rule below would take it, but does not replace (seed 146's fork: -1.8 px)
                seen_right = abs(d_out - d) <= 3.0
            elif LONE_FLAT_OUTVOTED and len(parents) == 1 and child_ok and outvoted(d, at(child), d_out) \
                    and not reached:
                # the child's curve and its right outline agree with each other, not with the lone flat side:
                # the three readings' mean (forkvouch.outvoted: seed 378's fork 11)
                d, agree = float((d + at(child) + d_out) / 3.0), True
            elif FLAT_PICK and abs(d_out - d) <= 1.0:
                seen_right = True       # the child's outline in the right view leaves the parent there too
            elif 1.0 < abs(d_out - d) <= OUTLINE_MAX_SHIFT_PX and not (child_ok and _agree(at(child), d)) \
                    and not reached \
                    and not (OUTLINE_NOT_OVER_CONFIRMED and any(s in flat_read for s in parents)):
                if child not in self.curves:            # (checked again: recheck_outline_forks)
                    self._from_outline[int(node)] = (child, d)
                d, agree = d_out, True
        from_outline = agree
        self.uvd[node] = np.array([xy[0], xy[1], d])
        self.radius[node] = rad[child]
        agree = agree or seen_right or child_ok and _agree(at(child), d)
        # the disparity the fork takes from the pieces whose fits reach it, if it agrees (below); a
        # provisional place (no outline) is hidden whatever agrees: its checks run only when that
        # disparity would differ (the same results, the work skipped otherwise)
        d_known = self._known_disparity(parents, child, child_ok, xy, d, at, side_near) \
            if parents and not from_outline else None
        if d_known is not None and SHORT_SIDE_NOT_KNOWN and not known_side_stands(d_known, {
                s: (at(s), self.curves[s].t_range, _t_at(self.curves[s], xy)) for s in parents if s not in side_near}):
            d_known = None          # (a side known only by the 12 px floor: forkvouch.py)
        out = e2 if np.dot(c2 - xy, e2) >= 0 else -e2      # (the child's direction away from the fork)
        if parents and not agree and outline is not None:     # the child's outline in the right view
            agree = self._outline_agrees(xy, outline[1], c2, e2, parents, r_par, rad[child], e_sides=e1)
        if parents and not agree and along and ALONG_RIGHT:    # ... or its merged silhouette in the right view
            agree = self._along_agrees(xy, p0, e1, out, d, r_par, rad[child])
        elif parents and not agree and outline is not None and ALONG_CONFIRMS and final:
            # a place from the child's outline that the merged silhouette places too (within ALONG_NEAR_PX), the
            # child's depth from that construction in the right view
            o_j = e2 if np.dot(c2 - p0, e2) >= 0 else -e2
            hit = along_fork(self.sm.left_mask, p0, e1, o_j, r_par, rad[child])
            agree = hit is not None and float(np.hypot(*(hit[0] - xy))) <= ALONG_NEAR_PX \
                and self._along_agrees(hit[0], p0, e1, o_j, d, r_par, rad[child])
        if parents and not agree and outline is not None and child not in self.curves \
                and abs(e2[1]) < FLAT_CHILD_SIN:      # a child along the rows: its bark texture (forkchild.py)
            agree = child_texture_agrees(self.sm.left_gray, self.sm.right_gray, xy, out,
                                         float(((near[child] - xy) @ out).min()), d, rad[child],
                                         self.sm.f_px, self.sm.offset_px)
        if parents and not agree and (final or d_known is not None):   # the child's own crossings next to the parent
            # (compiled: kernels_walks.near_points, the same selection as np.hypot's)
            pts = kernels_walks.near_points(self.seg_points(child), float(p[0]), float(p[1]), 1.2 * r, 1.2 * r + 60)[0]
            agree = self._runs_agree(pts, d, rad[child])
        if parents and agree and outline is not None:      # a branch running on past the parent crosses it: no fork
            sin_t = abs(outline[1][0] * e2[1] - outline[1][1] * e2[0])
            agree = not passes_through(self.sm.left_mask, xy, out, r_par / max(sin_t, 0.2) + 2.0, rad[child])
        front_d = None
        if agree and CROSSING_IN_FRONT and final and child_ok and len(segs) == 3 and crossing_in_front(
                (rad[pa], rad[pb]), float(np.dot(dirs[pa], dirs[pb])), rad[child], d, float(at(child)), self.sm.f_px):
            if CROSSING_IN_FRONT_PLACED:
                front_d = d + front_step_px(d, max(rad[pa], rad[pb]), self.sm.f_px)    # (set last, below)
            else:
                agree = False
        if agree and d_known is not None:
            self.uvd[node][2] = d_known
        elif agree and SIDES_WEIGHTED and final and len(d_par) == 2 and all(self.curves[s].by_row for s in parents):
            apart = abs(d_par[0] - d_par[1]) > SIDES_WEIGHT_PX
            rows = [self._side_rows(s, xy, side_near.get(s)) for s in parents]
            if SIDES_BENT and bent_sides_apply(rows, [s in side_near for s in parents]):
                # each side weighted by how far it is carried to the fork (the parent bends in depth), and
                # where they disagree beyond their rows' noise by those rows too (forkdisp.weigh_bent_sides)
                self.uvd[node][2] = weigh_bent_sides(d_par, rows, apart)
            elif apart:
                # the two steep sides disagree beyond their rows' noise (the checks above took their mean):
                # each weighted by how well its line is known at the fork (fewer rows, carried further: the less)
                self.uvd[node][2] = weigh_sides(d_par, rows)
        if agree and SIDES_CONFLICT_WITHHELD and final and self._sides_conflict(parents, xy, d_par, side_near):
            agree = False
        if agree and LONE_SIDE_WITHHELD and final and len(parents) == 1 and not child_ok \
                and not side_near and self.curves[parents[0]].by_row and self._reach(parents[0], xy) > 0:
            agree = False
        if agree and LONE_FAR_WITHHELD and final and len(parents) == 1 and self.curves[parents[0]].by_row \
                and parents[0] in side_near and side_near[parents[0]].nearest_px > LONE_FAR_PX \
                and child_ok and self._carried_px(child, xy) > LONE_FAR_PX:
            agree = False
        if agree and LONE_FAR_UNREAD_WITHHELD and final and len(parents) == 1 and self.curves[parents[0]].by_row \
                and parents[0] not in side_near and child_ok and (
                    self._carried_px(parents[0], xy) > LONE_FAR_PX and self._carried_px(child, xy) > LONE_FAR_PX
                    or short_side_unconfirmed(self.curves[parents[0]].t_range, *self._carry_d(child, xy))):
            agree = False
        if agree and LONE_BARK_WITHHELD and final and len(parents) == 1 and self.curves[parents[0]].by_row \
                and parents[0] not in side_near and self._carried_px(parents[0], xy) > CHILD_CARRY_PX:
            d_bark = steep_side_bark(self.sm.left_gray, self.sm.right_gray, self.curves[parents[0]],
                                     _t_at(self.curves[parents[0]], xy), 1.2 * rad[child] + 2.0, self.sm.f_px,
                                     self.sm.offset_px)
            agree = d_bark is None or abs(d_bark - float(self.uvd[node][2])) <= LONE_BARK_PX
        if agree and LONE_READ_WITHHELD and final and len(parents) == 1 and self.curves[parents[0]].by_row \
                and parents[0] in side_near and abs(side_near[parents[0]].d_px - self.uvd[node][2]) > LONE_READ_PX:
            agree = False
        if agree and NONE_KNOWN_WITHHELD and final and sides is not None and none_vouched(
                {s: (self.curves[s].t_range, _t_at(self.curves[s], xy)) for s in (*parents, child)}, bool(side_near)):
            agree = False
        if agree and STEEP_NONE_AGREE_WITHHELD and final and sides is not None \
                and all(self.curves[s].by_row for s in parents) \
                and all(abs(at(child) - v) > max(2.0, 0.012 * abs(v)) for v in sides):
            agree = False
        if agree and SCATTERED_READ_WITHHELD and final and len(parents) == 1 and parents[0] in flat_read \
                and parents[0] in side_near and scattered_read_contradicted(   # (flat_read: d_out was set)
                    float(self.uvd[node][2]), side_near[parents[0]].mad_px, d_out, child_ok and _agree(at(child), d)):
            agree = False
        if agree and SCATTERED_READ_WITHHELD and FLAT_NEAR_SHIFT_UNMOVED and final and len(parents) == 1 \
                and parents[0] in unmoved and scattered_read_contradicted(
                    unmoved[parents[0]].d_px, unmoved[parents[0]].mad_px, d_out,
                    child_ok and _agree(at(child), unmoved[parents[0]].d_px)):
            agree = False           # (the same check on the side's unmoved patches: FLAT_NEAR_SHIFT_UNMOVED)
        if agree and CHILD_ELSEWHERE_WITHHELD and final and child not in self.curves and outline is not None:
            sin_c = abs(float(outline[1][0] * out[1] - outline[1][1] * out[0]))
            agree = not child_texture_elsewhere(self.sm.left_gray, self.sm.right_gray, xy, out,
                                                r_par / max(sin_c, 0.2) + 2.0, float(self.uvd[node][2]), rad[child],
                                                self.sm.f_px, self.sm.offset_px)
        if unread_apart and final:
            agree = False           # (UNREAD_SIDES_APART: the child and its right outline disagree)
        if agree and LONE_CARRIED_CONTRADICTED_WITHHELD and final and d_out is not None and len(parents) == 1 \
                and not from_outline and parents[0] not in side_near \
                and self._carried_px(parents[0], xy) > CHILD_CARRY_PX and float(self.uvd[node][2]) == d \
                and abs(d_out - d) > OUTLINE_MAX_SHIFT_PX and not (child_ok and _agree(at(child), d)):
            agree = False           # (a flat parent: d_out is set only there)
        if LONE_CARRIED_MEDIAN and final and d_out is not None and len(parents) == 1 and child_ok \
                and not from_outline and parents[0] not in side_near \
                and self._carried_px(parents[0], xy) > CHILD_CARRY_PX and (float(self.uvd[node][2]) == d or (
                    CARRIED_CHILD_MEDIAN and float(self.uvd[node][2]) == float(at(child))
                    and self._carried_px(child, xy) > CHILD_CARRY_PX
                    and not vouched_by_span(self.curves[child].t_range, _t_at(self.curves[child], xy)))):
            # (a flat parent: d_out is set only there; the fork's disparity still the side's own, no rule took another)
            self.uvd[node][2] = lone_carried_median(d, float(at(child)), d_out)
        if THROUGH_FORK and final and agree and outline is not None and len(parents) == 1 \
                and self.curves[parents[0]].by_row and float(self.uvd[node][2]) == float(at(parents[0])):
            # (after every decision, so which forks are reported is unchanged: the lone side's value replaced)
            v = self._through_fork(parents[0], pb if parents[0] == pa else pa, xy, side_near.get(parents[0]))
            if v is not None:
                self.uvd[node][2] = v.d_px
                side_near[parents[0]] = v
        if FLAT_CHILD_READ and final and agree and outline is not None and parents and child_ok \
                and self.curves[child].by_row and not all(self.curves[s].by_row for s in parents):
            # (after every decision: a flat parent's fork and its steep child's own rows next to it, the mean)
            v = self._child_read(child, xy)
            if v is not None:
                self.uvd[node][2] = 0.5 * (float(self.uvd[node][2]) + v.d_px)
        elif LONE_FLAT_CHILD_READ and final and agree and outline is not None and len(parents) == 1 and child_ok \
                and self.curves[child].by_row and not self.curves[parents[0]].by_row and parents[0] not in side_near \
                and parents[0] in flat_read and float(self.uvd[node][2]) == float(at(parents[0])) \
                and 0.0 < self._carried_px(parents[0], xy) <= CHILD_CARRY_PX:
            # (after every decision: a lone flat side's level carried to the fork, and the steep child's own rows)
            v = self._child_read(child, xy, LONE_FLAT_CHILD_READ_PX)
            if v is not None:
                self.uvd[node][2] = 0.5 * (float(self.uvd[node][2]) + v.d_px)
        elif MEDIAN_FLAT_CHILD_READ and final and agree and outline is not None and sides is not None and child_ok \
                and self.curves[child].by_row and any(
                    not self.curves[s].by_row and s not in side_near and s in flat_read
                    and float(self.uvd[node][2]) == float(at(s)) and 0.0 < self._carried_px(s, xy) <= CHILD_CARRY_PX
                    for s in parents):
            # (after every decision: the median of three took a flat side's level carried a few px to the fork)
            v = self._child_read(child, xy, LONE_FLAT_CHILD_READ_PX)
            if v is not None:
                self.uvd[node][2] = 0.5 * (float(self.uvd[node][2]) + v.d_px)
        r_mean = sum(self.curves[s].radius_px for s in parents) / max(len(parents), 1)
        if CENTRE_TO_AXIS and final and parents and r_mean <= CENTRE_MAX_RADIUS_PX \
                and all(self._steep_known(s, xy, side_near) for s in parents):
            self.uvd[node][2] -= centre_bias_px(float(self.uvd[node][2]), float(xy[0]), r_mean,
                                                self.sm.f_px, self.sm.cx_px, self.sm.offset_px)
        if front_d is not None:
            self.uvd[node][2] = front_d     # (a thin branch crossing in front: at the parent's front surface)
        if not parents or not agree or outline is None:
            # (without the child's outline the fork's place is only the slide back along the
            # parent, mostly 10-100 px off: withheld)
            self.hidden.add(int(node))
        else:
            self.hidden.discard(int(node))

    def _near_dir(self, s: int, p: np.ndarray, r: float) -> tuple[np.ndarray, float, np.ndarray]:
        """Piece ``s``'s skeleton points within ``r`` px of the junction ``p`` (2,) (fewer than 3: its 15 nearest, by
        numpy's sort where tied distances leave their order to it), their radius (px) and the piece's direction (2,)
        from ``p`` (``kernels_forknear.near_or_nearest``: ``_near_points`` and the direction in one compiled call)."""
        seg_pts = self.seg_points(s)
        pts, dist, u, ok = kernels_forknear.near_or_nearest(seg_pts, float(p[0]), float(p[1]), float(r))
        if not ok:
            pts = seg_pts[np.argsort(dist)[:15]]
            v = pts.sum(0) / len(pts) - p
            u = v / max(np.hypot(*v), 1e-9)
        return pts, self._seg_radius(s, pts), u

    def _outline_place_from(self, segs: list, p: np.ndarray, r: float) -> tuple[np.ndarray | None, float]:
        """Where the child's outline places a fork of pieces ``segs`` taken as meeting at ``p`` (2,) px, their points
        within ``r`` px of it (the parent, child and lines chosen as ``fork`` does, without its caches; the parent's
        line behind the fork first, then through both sides), None when the outline gives no place; and how far ``p``
        lies from the parent's line through both sides, in parent radii."""
        near, rad, dirs = {}, {}, {}
        for s in segs:
            near[s], rad[s], dirs[s] = self._near_dir(s, p, r)
        pa, pb = _parent_pair(segs, rad, dirs)
        child = next(s for s in segs if s not in (pa, pb))
        c1, e1 = kernels_forks.tls_line_pair(near[pa], near[pb])
        c2, e2 = _line(near[child])
        behind = min((pa, pb), key=lambda s: np.dot(dirs[s], dirs[child]))
        r_par = max(rad[pa], rad[pb])
        off = abs(float((p[0] - c1[0]) * e1[1] - (p[1] - c1[1]) * e1[0])) / max(r_par, 1.0)
        for cl, el in ([_line(near[behind])] if len(near[behind]) >= 3 else []) + [(c1, e1)]:
            xy = self._fork_from_child_outline(cl, el, c2, e2, cl + np.dot(p - cl, el) * el, r_par, rad[child])
            if xy is not None:
                return xy, off
        return None, off

    def _split_pair_place(self, node: int, other: int, segs: list) -> np.ndarray | None:
        """Where a split junction's pair (``SPLIT_JUNCTION``) is one fork (``SPLIT_CHECKED``): the child's outline
        places it alike taken from either node of the pair (within ``SPLIT_AGREE_PX``), one node lies at least
        ``SPLIT_OFF_AXIS`` parent radii off the parent's line (the child's, near the parent's outline), and no piece of
        another branch passes over that place (within ``SPLIT_CLEAR_PX`` beyond its radius: a crossing). The two
        places' mean (2,) px; None otherwise (not placed)."""
        (q0, off0), (q1, off1) = (self._outline_place_from(segs, self.node_xy[n], self._node_radius(n))
                                  for n in (node, other))
        if q0 is None or q1 is None or np.hypot(*(q0 - q1)) > SPLIT_AGREE_PX:
            return None
        if max(off0, off1) < SPLIT_OFF_AXIS:
            return None             # (both nodes deep inside the parent: its own skeleton split, seed 643 T5)
        xy = 0.5 * (q0 + q1)
        own = set(self.incident[node]) | set(self.incident[other])
        for s in range(len(self.g.seg_yx)):
            if s in own or not self._usable(s):
                continue
            pts = self.seg_points(s)
            reach = max(self._seg_radius(s, pts), 1.0) + SPLIT_CLEAR_PX
            if float(np.min(np.hypot(pts[:, 0] - xy[0], pts[:, 1] - xy[1]))) <= reach:
                return None
        return xy

    def _usable(self, s: int) -> bool:
        """Whether piece ``s`` takes part in a fork (seen, not bridged; two skeleton points or more)."""
        return not self.g.seg_recovered[s] and len(self.g.seg_yx[s]) >= 2

    def _split_partner(self, node: int) -> int | None:
        """The junction joined to ``node`` by a one-point piece, where the two are one fork split in two
        (``SPLIT_JUNCTION``): each has fewer than three usable pieces of its own, together ``SPLIT_PIECES`` (a Y;
        four are a crossing or a fork beside one: measured, not taken). Only the pair's lower node takes it (the other
        returns as before: one fork per pair). None otherwise."""
        for s in self.incident[node]:
            if self.g.seg_recovered[s] or len(self.g.seg_yx[s]) >= 2:
                continue
            other = next((m for m in self.g.seg_nodes[s] if m >= 0 and m != node), None)
            if other is None or other < node or self.g.node_kind[other] != JUNCTION:
                continue
            mine = {t for t in self.incident[node] if self._usable(t)}
            theirs = {t for t in self.incident[other] if self._usable(t)}
            if len(theirs) < 3 and len(mine | theirs) == SPLIT_PIECES:
                return int(other)
        return None

    def _child_read(self, child: int, xy: np.ndarray, reach_px: float = FLAT_CHILD_READ_PX) -> "SideNear | None":
        """A steep child's own disparity at the fork ``xy`` (2,) from its crossings nearest it, read as a parent side's
        (:func:`forkdisp.side_disparity_near`: its rows clear of the crotch, as wide as its span's, and its span's
        next to them, a line read at the fork's row), where its kept rows come within ``FLAT_CHILD_READ_PX`` of the
        fork (``FLAT_CHILD_READ``; ``reach_px``, px); None otherwise."""
        c = self.curves[child]
        v = side_disparity_near(c, self.runs_l, self.runs_r, _t_at(c, xy), f_px=self.sm.f_px, cx_px=self.sm.cx_px,
                                offset_px=self.sm.offset_px)
        return v if v is not None and v.nearest_px <= reach_px else None

    def _through_fork(self, s: int, other: int, xy: np.ndarray, v0) -> "SideNear | None":
        """A lone steep parent side ``s``'s read through the fork ``xy`` (2,) (``THROUGH_FORK``): where its own read
        ``v0`` (a :class:`forkdisp.SideNear`, or None: carried unread) stops more than ``THROUGH_SHORT_PX`` short of
        the fork, the parent's crossings past the fork, as far as the other parent piece ``other`` (no curve through
        the fork) runs on in rows, read with its own (:func:`forkdisp.side_through_fork`); taken where its kept
        rows come within ``SIDE_KNOWN_PX`` of the fork and nearer than ``v0``'s, moving the side's value (``v0``'s, or
        its curve's) by at most ``THROUGH_MAX_MOVE_PX``. None: ``v0`` stands."""
        c = self.curves[s]
        t = _t_at(c, xy)
        lo, hi = c.t_range
        if lo - THROUGH_SHORT_PX < t < hi + THROUGH_SHORT_PX or (v0 is not None and v0.nearest_px <= THROUGH_SHORT_PX):
            return None
        rows = self.seg_points(other)[:, 1]
        past = float(t - rows.min()) if t < lo else float(rows.max() - t)
        v = side_through_fork(c, self.runs_l, self.runs_r, t, past, self.sm.left_mask.shape[0], f_px=self.sm.f_px,
                              cx_px=self.sm.cx_px, offset_px=self.sm.offset_px)
        if v is None or v.nearest_px > SIDE_KNOWN_PX or (v0 is not None and v.nearest_px >= v0.nearest_px):
            return None
        d0 = v0.d_px if v0 is not None else float(_d_at(c, float(xy[0]), float(xy[1])))
        return v if abs(v.d_px - d0) <= THROUGH_MAX_MOVE_PX else None

    def _mean_sides(self, parents: list, xy: np.ndarray, side_near: dict) -> list:
        """The parent sides whose disparities at the fork ``xy`` (2,) enter its mean: both of two sides but a
        flat one not read next to the fork (``side_near``: {piece: :class:`forkdisp.SideNear`}) that is no reading
        there (:func:`forkvouch.short_turning_flat_side`: fitted on a few columns, carried past half of them,
        turning in depth at the fork), where the other side is not such a side too; ``parents`` otherwise."""
        if len(parents) != 2:
            return parents
        def no_reading(c: BranchCurve) -> bool:
            t = _t_at(c, xy)
            return short_turning_flat_side(c.t_range, t, turns_in_depth(c, t))
        short = [s for s in parents if not self.curves[s].by_row and s not in side_near and no_reading(self.curves[s])]
        return [s for s in parents if s not in short] if len(short) == 1 else parents

    def _sides_conflict(self, parents: list, xy: np.ndarray, d_par: list, side_near: dict) -> bool:
        """Whether a fork's two steep parent sides, both known at ``xy`` (2,) from their own rows there,
        give disparities ``d_par`` (two, px) that are not of one branch (:func:`_agree`): no carry to
        blame, one side's rows next to the fork are another shape's in one view, and nothing tells
        which (each side known there: :meth:`_steep_known`)."""
        if len(parents) != 2 or len(d_par) != 2 or _agree(d_par[0], d_par[1]):
            return False
        return all(self._steep_known(s, xy, side_near) for s in parents)

    def _steep_known(self, s: int, xy: np.ndarray, side_near: dict) -> bool:
        """Whether parent side ``s`` is steep and known at the fork ``xy`` (2,) from its own row crossings:
        read within ``SIDE_KNOWN_PX`` of it (``side_near``: {piece: :class:`forkdisp.SideNear`}) or, not read,
        its fitted span reaching it (:meth:`_reach` <= 0)."""
        return self.curves[s].by_row and (side_near[s].nearest_px <= SIDE_KNOWN_PX if s in side_near
                                          else self._reach(s, xy) <= 0)

    def _radius_at_fork(self, parents: list, xy: np.ndarray, others: list = (), rad: dict | None = None,
                        near: dict | None = None) -> float | None:
        """The parent's radius (px) at the fork ``xy`` (2,) from its two sides' (each its span's mean,
        taken at the span's middle): a branch tapers along its length, so the distal side's radius is
        smaller than at the fork and the proximal one's larger; linear between the two middles by their
        distances in the image. With one fitted side through the fork (``parents``), the other side
        (``others``: without a curve, or its curve not through the fork) stands in with its radius
        ``rad[s]`` measured at its centre-line points ``near[s]`` (K, 2) next to the fork
        (:meth:`_near_points`, :meth:`_seg_radius`), where the two tell a taper (``LONE_TAPER``,
        ``LONE_MAX_TAPER``). None otherwise (the side's own stands)."""
        sides = [(self.curves[s].radius_px,
                  float(np.hypot(*(self.curves[s].uv_at(np.array([0.5 * sum(self.curves[s].t_range)]))[0] - xy))))
                 for s in parents]
        if LONE_TAPER and len(sides) == 1 and len(others) == 1 and rad is not None and near is not None:
            o = others[0]
            r_o, d_o = float(rad[o]), float(np.hypot(*(near[o].mean(0) - xy)))
            # (the map's radii are good to ~scale / 2 px each: within its scale the two do not tell a taper)
            if getattr(self.sm.radius_map, "scale", 1) < abs(r_o - sides[0][0]) <= LONE_MAX_TAPER * (sides[0][1] + d_o):
                sides.append((r_o, d_o))
        if len(sides) != 2:
            return None
        (ra, da), (rb, db) = sides
        return taper_radius(ra, da, rb, db)

    def recheck_outline_forks(self) -> None:
        """Forks on a flat parent whose disparity the right outline of a child without a curve
        set (:meth:`fork`) take the parent's own back where the child has since gained a stub's
        curve (caps.py) more than ``CHILD_DEPTH_PX`` from the parent's at its end next to the
        fork: a child pointing steeply in depth, whose right outline leaves the parent where the
        child is already nearer or further (seed 145's fork: +1.3 px from the outline, the
        parent's texture +0.3)."""
        for node, (child, d_par) in self._from_outline.items():
            c = self.curves.get(child)
            if c is None or node not in self.uvd:
                continue
            lo, hi = c.t_range
            t = float(c.t_of(self.node_xy[node])[0])
            d_child = float(c.d_at(hi if abs(t - hi) <= abs(t - lo) else lo)[0])
            if abs(d_child - d_par) > CHILD_DEPTH_PX:
                self.uvd[node][2] = d_par

    def _carried_px(self, s: int, xy: np.ndarray) -> float:
        """How far (in its parameter: rows or columns) piece ``s``'s curve is carried past its
        fitted span to reach ``xy`` (2,); 0 inside it."""
        c = self.curves[s]
        lo, hi = c.t_range
        t = _t_at(c, xy)
        return max(lo - t, t - hi, 0.0)

    def _carry_d(self, s: int, xy: np.ndarray) -> tuple[float, float]:
        """Piece ``s``'s curve's disparity at ``xy`` (2,) and at its fitted span's end nearer it (inside the span:
        the same), px."""
        c = self.curves[s]
        lo, hi = c.t_range
        t = _t_at(c, xy)
        return float(c.d_at(t)[0]), float(c.d_at(min(max(t, lo), hi))[0])

    def defer_forks(self, nodes) -> None:
        """Provisional forks (:meth:`fork`, not final) of ``nodes``, made only when read (their
        place: :meth:`place_pending`, by a flat piece's ends or a final round that finds no place),
        with the curves as they are now: the same places as making them now. The final round
        replaces every other one whole (place, radius, hidden), so those are never made."""
        self._pending.update(int(n) for n in nodes)
        self._pending_curves = dict(self.curves)

    def place_pending(self, node: int) -> None:
        """Make ``node``'s provisional fork now if it is still pending (:meth:`defer_forks`)."""
        if node not in self._pending:
            return
        self._pending.discard(node)
        now, self.curves = self.curves, self._pending_curves
        try:
            self.fork(node)
        finally:
            self.curves = now

    def _known_disparity(self, parents: list, child: int, child_ok: bool, xy: np.ndarray, d: float,
                         at, near=None) -> float | None:
        """The disparity (px) an agreed fork at ``xy`` (placed at disparity ``d``) takes from the pieces
        whose fits reach it (a piece fitted on a few rows and carried far past them is barely known
        there), where the others move it by more than half a pixel (within that, both sides' means
        average out the crotch's bias on each), or, when none reaches it, from the one carried
        clearly least far; None to keep ``d``. ``at(s)``: piece s's disparity at
        the fork; ``near``: {piece: :class:`forkdisp.SideNear`} of the sides read from their own crossings
        nearest the fork (known there if one lies within 12 px; a flat side's texture patches only if they
        agree, ``FLAT_READ_VOUCH_MAD_PX``). The child's span vouches for at most ``KNOWN_VOUCH_MAX_PX``."""
        vouch = KNOWN_VOUCH_MAX_PX if KNOWN_VOUCH_CAPPED else math.inf
        reach = {s: self._reach(s, xy, vouch if s == child else math.inf) for s in (*parents, child) if s in self.curves}
        read = set()
        for s, v in (near or {}).items():           # (read from rows within 12 px of the fork: known there)
            if FLAT_READ_VOUCHES or self.curves[s].by_row or v.mad_px <= FLAT_READ_VOUCH_MAD_PX:
                reach[s] = min(reach[s], v.nearest_px - 12.0)
                if v.nearest_px <= 12.0:
                    read.add(s)
        near_p = [s for s in parents if reach[s] <= 0]
        if FLOOR_SIDE_UNKNOWN_BY_READ and len(near_p) == 2 and read.intersection(near_p):
            # a side read next to the fork stands alone against one known only by the 12 px floor (forkvouch.py)
            near_p = [s for s in near_p if s in read or vouched_by_span(self.curves[s].t_range, _t_at(self.curves[s], xy))]
        if near_p and len(near_p) < len(parents):
            d_near = float(sum(at(s) for s in near_p) / len(near_p))      # (np.mean's value of one)
            return d_near if abs(d_near - d) > 0.5 else None
        if not near_p and child_ok and reach[child] <= 0:
            read_p = [s for s in parents if s in (near or {}) and self.curves[s].by_row
                      and near[s].nearest_px <= READ_OVER_CHILD_PX] \
                if READ_OVER_FLOOR_CHILD and self._carried_px(child, xy) > 0 else []
            if read_p:              # (a side read next to the fork against the child known only by the floor)
                d_read = float(sum(at(s) for s in read_p) / len(read_p))
                return d_read if abs(d_read - d) > 0.5 else None
            return float(at(child))
        if not near_p:
            # none reaches it: the one carried clearly least far (12 px less than any other)
            cand = sorted((reach[s], s) for s in (*parents, *([child] if child_ok else [])))
            if len(cand) >= 2 and cand[0][0] < cand[1][0] - 12.0:
                d_best = float(at(cand[0][1]))
                return d_best if abs(d_best - d) > 0.5 else None
        return None

    def _side_rows(self, s: int, xy: np.ndarray, near=None) -> tuple[float, float]:
        """How a steep parent side's disparity at the fork ``xy`` (2,) is known: (rows, rows past the
        nearest) of its own crossings read nearest the fork (``near``: a :class:`forkdisp.SideNear`),
        or else of its fitted span and how far its curve is carried (:func:`forkdisp.weigh_sides`)."""
        if near is not None:
            return float(near.n_rows), float(near.nearest_px)
        lo, hi = self.curves[s].t_range
        return hi - lo, self._carried_px(s, xy)

    def _reach(self, s: int, xy: np.ndarray, vouch_max_px: float = math.inf) -> float:
        """How far (px of t) piece ``s``'s curve is carried past its fitted span to reach ``xy``,
        beyond what its span vouches for (half the span, at least 12, at most ``vouch_max_px``): <= 0
        when it is known there."""
        c = self.curves[s]
        lo, hi = c.t_range
        t = _t_at(c, xy)
        return max(lo - t, t - hi) - max(12.0, min(0.5 * (hi - lo), vouch_max_px))

    def _fork_from_child_outline(self, c1, e1, c2, e2, p0, r_par: float, r_child: float,
                                 mask: np.ndarray | None = None) -> np.ndarray | None:
        """The fork from the child's outline where it leaves the parent: None when unclear.

        Lines parallel to the parent's axis (``c1``, ``e1``), just clear of the parent's outline
        on the child's side, cross the child in an interval whose middle is the child's axis
        (its two edges are parallel); the middles on two such lines give the child's axis, whose
        crossing with the parent's axis is the fork. The child's line (``c2``, ``e2``) only
        tells which crossing is the child's. Intervals not as wide as the child seen at that
        angle (hidden by a leaf, merged with something) make a pair of lines unclear; a pair
        further out is tried then. The intervals' ends are where the mask's coverage (0-255,
        bilinear) crosses 128, to a fraction of a pixel. ``mask``: the left view's unless given.
        """
        mask = self.sm.left_mask if mask is None else mask
        # (compiled whole: kernels_forks.child_outline_fork; its scans kernels_walks.child_outline_pairs, the
        # values of _line_samples + _interval_middle, the mask read only where the scans look)
        found, xy = kernels_forks.child_outline_fork(np.ascontiguousarray(mask), *(np.ascontiguousarray(v, float) for v in (
            c1, e1, c2, e2, p0)), float(r_par), float(r_child))
        return xy if found else None

    def _outline_agrees(self, xy, e1, c2, e2, parents: list, r_par: float, r_child: float, e_sides=None) -> bool:
        """Whether the child's outline in the right view leaves the parent at the fork too.

        The parent's axis in the right view is the left one moved by its disparity; the fork
        found there from the child's right outline must be the left fork moved by the parent's
        disparity (within 1.6 px or 0.9 %: each view's place is ~1 px off): a child at another
        depth crosses the parent elsewhere. A child so near the rows that a depth difference of
        ``OUTLINE_MAX_D_PX`` would move its crossing less than that cannot tell: False. A shallow
        child's places are compared in disparity too (``OUTLINE_SHALLOW``: forkoutline.py; ``e_sides``: the
        direction of the line through both parent sides, which the parent's line ``e1`` must follow there).
        """
        def right_of(pt):
            ds = [self.curves[s].d_at(self.curves[s].t_of(pt))[0] for s in parents]
            d = sum(ds) / len(ds)          # (np.mean's value of one or two: the same sum and division)
            return pt - np.array([d, 0.0]), d
        r1, d1 = right_of(xy)
        r2, _ = right_of(xy + 30.0 * e1)
        er = (r2 - r1) / max(np.hypot(*(r2 - r1)), 1e-9)
        tol = max(1.6, 0.009 * d1)
        # a child at another depth by D px crosses the parent D |e2_y| / sin(angle) px further
        # along it in the right view: a child near the rows (a crossing branch) moves too little
        if tol * abs(er[0] * e2[1] - er[1] * e2[0]) > OUTLINE_MAX_D_PX * abs(e2[1]):
            return False
        xy_r = self._fork_from_child_outline(r1, er, c2 - np.array([d1, 0.0]), e2, r1, r_par, r_child,
                                             self.sm.right_mask)
        if xy_r is None:
            return False
        if np.hypot(*(xy_r - r1)) <= tol:
            return True
        return OUTLINE_SHALLOW and e_sides is not None and shallow_outline_agrees(xy_r - r1, er, e1, e_sides, e2, tol)

    def _along_agrees(self, xy, p0, e1, out, d: float, r_par: float, r_child: float) -> bool:
        """Whether the right view's merged silhouette places a child lying along its parent (``forkalong``) at
        the left place ``xy`` moved by the fork's disparity ``d`` (within ``ALONG_RIGHT_PX``, or 0.9 % of
        ``d``): a child at another depth leaves the parent's outline elsewhere in the right view, tens of px
        away at these angles. ``p0``: the junction on the parent's line (direction ``e1``) in the left view;
        ``out``: the child's direction away from the fork."""
        shift = np.array([d, 0.0])
        hit = along_fork(self.sm.right_mask, p0 - shift, e1, out, r_par, r_child)
        return hit is not None and float(np.hypot(*(hit[0] - (xy - shift)))) <= max(ALONG_RIGHT_PX, 0.009 * d)

    def _flat_fork_disparity(self, xy, e1, c2, e2, d: float, r_par: float, r_child: float) -> float | None:
        """The disparity of a fork on a flat parent (axis direction ``e1`` within ~25 deg of the
        rows) from the child's outline in the right view: the fork found there on the parent's
        axis (the left one moved by ``d``, along the rows) lies on the same row, moved by the
        fork's own disparity. None when unclear or not on the row (1 px)."""
        if abs(e1[0]) < 0.9:
            return None
        r1 = xy - np.array([d, 0.0])
        xy_r = self._fork_from_child_outline(r1, e1, c2 - np.array([d, 0.0]), e2, r1, r_par, r_child,
                                             self.sm.right_mask)
        if xy_r is None or abs(xy_r[1] - xy[1]) > 1.0:
            return None
        return float(xy[0] - xy_r[0])

    @staticmethod
    def _child_crossings(lines: list, e, r_child: float, sin_t: float, mask: np.ndarray) -> list:
        """Middles (parameter s along each line ``base + s e``, for each ``(base, s_c)`` of ``lines``)
        of the ``mask`` interval at or nearest to ``s_c``, where it is as wide as a piece of radius
        ``r_child`` crossed at sine ``sin_t``; else None. The mask is read once for all lines."""
        return [ForkPlacing._interval_middle(*sv, r_child, sin_t)
                for sv in ForkPlacing._line_samples(lines, e, r_child, sin_t, mask)]

    @staticmethod
    def _line_samples(lines: list, e, r_child: float, sin_t: float, mask: np.ndarray) -> list:
        """:meth:`_child_crossings`' samples: for each ``(base, s_c)`` of ``lines``, the parameters
        ``s`` (1 px apart, around ``s_c``), the ``mask`` along ``base + s e`` there (bilinear; one
        read for all lines: each point's value is its own) and ``s_c``."""
        reach = (4.7 * r_child + 3) / sin_t + 2          # the interval nearest s_c, whole, if as wide
        ss = [np.arange(s_c - reach, s_c + reach, 1.0) for _, s_c in lines]
        n = [len(s) for s in ss]
        s_all = np.concatenate(ss)
        uv = np.repeat(np.array([base for base, _ in lines]), n, axis=0) + s_all[:, None] * e
        val = ForkPlacing._bilinear(mask, uv)
        out, i0 = [], 0
        for (_, s_c), s in zip(lines, ss):
            out.append((s, val[i0:i0 + len(s)], s_c))
            i0 += len(s)
        return out

    @staticmethod
    def _bilinear(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
        """``img`` (H, W) uint8 at points ``uv`` (N, 2) (x, y), bilinear (1/32 px); 0 outside."""
        m = uv.astype(np.float32)
        parts = [cv2.remap(img, m[i:i + 16384].reshape(1, -1, 2), None, cv2.INTER_LINEAR,    # (OpenCV maps up
                           borderMode=cv2.BORDER_CONSTANT, borderValue=0)[0]                 # to 32767 wide)
                 for i in range(0, max(len(m), 1), 16384)]
        return parts[0] if len(parts) == 1 else np.concatenate(parts)

    @staticmethod
    def _interval_middle(s: np.ndarray, val: np.ndarray, s_c: float, r_child: float, sin_t: float) -> float | None:
        """Middle of the interval of ``val`` >= 128 (mask coverage 0-255 at the evenly spaced samples
        ``s``) nearest ``s_c``, its ends interpolated to where the coverage crosses 128, if it is as
        wide as the child crossed at ``sin_t``."""
        ds = s[1] - s[0]
        ic = int(np.rint((s_c - s[0]) / ds))
        w = int(2 * r_child / sin_t / ds)
        lo_i, hi_i = max(ic - w, 0), min(ic + w + 1, len(s))
        if lo_i >= hi_i:
            return None
        # (scans of the samples as Python ints, from the middle outwards: the same samples as
        # searching the lists of all "on" and "off" indices, ~4 against ~16 us a call)
        vals = val.tolist()
        c = min(max(ic, lo_i), hi_i - 1)           # the nearest "on" sample to s_c in the window
        k = None                                    # (at equal distances the one before)
        for dd in range(max(c - lo_i, hi_i - 1 - c) + 1):
            if c - dd >= lo_i and vals[c - dd] >= 128:
                k = c - dd
                break
            if c + dd < hi_i and vals[c + dd] >= 128:
                k = c + dd
                break
        if k is None:
            return None
        a = k - 1                                   # the last sample off before k
        while a >= 0 and vals[a] >= 128:
            a -= 1
        b = k + 1                                   # the first off after k
        while b < len(vals) and vals[b] >= 128:
            b += 1
        if a < 0 or b == len(vals):
            return None
        va, vb = float(vals[a]), float(vals[b])
        lo = s[a] + ds * (128.0 - va) / max(float(vals[a + 1]) - va, 1e-9)
        hi = s[b] - ds * (128.0 - vb) / max(float(vals[b - 1]) - vb, 1e-9)
        if abs((hi - lo) * sin_t - 2 * r_child) > 0.8 * r_child + 2:
            return None
        return 0.5 * (lo + hi)

    def _runs_agree(self, pts: np.ndarray, d: float, r: float, min_rows: int = 3) -> bool:
        """Whether a piece's own row crossings at points ``pts`` (N, 2) have disparity ``d``.

        On each row of the points the left crossing (not wider than a piece of radius ``r``
        across that row) is compared with the right crossings of a similar width in the
        working range; rows where one of them lies within :func:`_agree` of ``d`` must be at
        least ``min_rows`` and 60 % of the rows with any (rows merged with the parent in the
        right view have none). A piece within ~17 deg of the rows: False.
        """
        # (compiled whole: kernels_forks.runs_agree, the same steps)
        rl, rr = self.runs_l, self.runs_r
        dmin, dmax = self.sm.d_range_px
        return kernels_forks.runs_agree(np.ascontiguousarray(pts, float), float(d), float(r), int(min_rows),
                                        *rl._find_tables, rl.width, rl.span_px, rl.centre_px, rr._centre_keys,
                                        rr.width, rr.span_px, rr.centre_px, float(dmin), float(dmax))

    def _box(self, s: int) -> tuple[float, float, float, float]:
        """Bounding box (u0, v0, u1, v1) of a fitted piece's centre line (cached)."""
        box = self._box_cache.get(s)
        if box is None:
            c = self.curves[s]
            uv = c.uv_at(linspace(*c.t_range, 8))
            box = self._box_cache[s] = (*uv.min(0).tolist(), *uv.max(0).tolist())
        return box

    def hidden_fork(self, node: int, reach_px: float = 80.0) -> bool:
        """An end whose branch runs on, hidden (by a leaf, an apple), into another branch: the fork.

        The end's centre line, carried straight on for at most ``reach_px`` (along the branch:
        :func:`walk_reach_t`), crosses the centre
        line of a fitted piece at least as thick, at ``HIDDEN_FORK_MIN_DEG`` or more (at a
        shallower angle it is the branch itself running on, bent, behind the occluder); if the
        end's own disparity carried along agrees there with that piece's (:func:`_agree`), the
        crossing is the fork (with the parent's disparity) and the end is placed there.
        Returns whether it was.
        """
        if node not in self.hidden:
            return False
        segs = [s for s in self.incident[node] if s in self.curves]
        if not segs:
            return False
        c = self.curves[segs[0]]
        # (from the whole-pixel walk's end: its 1 px steps and checks were set with it; the sub-pixel
        # one only moves their grid, and flips borderline crossings, docs/localize-softmask.md)
        t_edge, sign = self._walk_out(c, node, whole=True)
        reach_t = walk_reach_t(c, t_edge, sign, reach_px)
        n_walk = math.ceil(reach_t)                 # (len(np.arange(0.0, reach_t, 1.0)))
        sp = c.s_poly
        if type(sp) is Poly and n_walk >= 2:       # (compiled: kernels_forkglue.walk_uv, the same points)
            lo, hi = c.t_range
            uv = kernels_forkglue.walk_uv(np.ascontiguousarray(sp.coef, float), np.ascontiguousarray(sp._deriv.coef, float),
                                          float(sp.t0), float(sp.ts), float(lo), float(hi), bool(c.by_row),
                                          float(t_edge), float(sign), n_walk)
        else:
            uv = c.uv_at(t_edge + sign * np.arange(0.0, reach_t, 1.0))
        # (the scan of all pieces compiled: kernels_forks.hidden_crossings, the same values)
        row, pieces, table = self._curve_table()
        cross = kernels_forks.hidden_crossings(uv, 0.8 * c.radius_px, row.get(segs[0], -1), *table)
        best = None
        for j in (cross != -1).nonzero()[0].tolist():      # (np.flatnonzero's indices, without its wrapper)
            k = int(cross[j]) if cross[j] >= 0 else self._hidden_crossing(uv, *pieces[j])
            if k >= 0 and (best is None or k < best[0]):
                best = (k, pieces[j][1])
        if best is None:
            return False
        k, c2 = best
        if HIDDEN_ON_FEW_PATCHES and few_patch_constant(
                c2.by_row, len(c2.d_poly.coef) if type(c2.d_poly) is Poly else 0, c2.n_samples):   # (Spliced: not one)
            return False
        xy = uv[k]
        t2 = c2.t_of(xy)[0]
        e2 = c2.uv_at(t2 + 1.0)[0] - c2.uv_at(t2 - 1.0)[0]
        e1 = uv[min(k + 1, len(uv) - 1)] - uv[max(k - 1, 0)]
        sin_t = abs(e1[0] * e2[1] - e1[1] * e2[0]) / max(np.hypot(*e1) * np.hypot(*e2), 1e-9)
        if sin_t < np.sin(np.radians(HIDDEN_FORK_MIN_DEG)):
            return False
        d_par = float(c2.d_at(_t_at(c2, xy))[0])
        d_child = float(c.d_at(_t_at(c, xy))[0])
        d_read = self._hidden_parent_read(c, c2, xy, e2, sin_t) if HIDDEN_SIDE_READ else None
        if d_read is not None:
            d_par = d_read
        if not _agree(d_child, d_par):
            return False
        self.uvd[node] = np.array([xy[0], xy[1], d_par])
        self.radius[node] = c.radius_px
        self.hidden.discard(int(node))
        return True

    def _hidden_parent_read(self, c: BranchCurve, c2: BranchCurve, xy: np.ndarray, e2: np.ndarray,
                            sin_t: float) -> float | None:
        """A hidden fork's parent disparity (px) at ``xy`` (2,) from the steep parent ``c2``'s own row crossings
        on each side of the crotch (forkhidden.py: the crotch's half length from the child ``c``'s radius, the
        parent's and the angle's sine ``sin_t``, in rows along the parent's direction ``e2``); None where no
        side is read (a flat parent, short or unread sides: its curve stands)."""
        if not c2.by_row:
            return None
        rows_per_px = abs(float(e2[1])) / max(float(np.hypot(*e2)), 1e-9)
        clear_t = crotch_half_px(c.radius_px, c2.radius_px, sin_t) * rows_per_px
        reads = hidden_side_reads(c2, self.runs_l, self.runs_r, _t_at(c2, xy), clear_t, f_px=self.sm.f_px,
                                  cx_px=self.sm.cx_px, offset_px=self.sm.offset_px)
        return hidden_parent_disparity(reads)

    def _curve_table(self) -> tuple[dict, list, tuple]:
        """The fitted pieces as :func:`kernels_forks.hidden_crossings`' arrays (cached while the curves
        stay): {piece: row}, the (piece, curve) of each row, and (by_row, t_lo, t_hi, radius, poly,
        coef, n_coef, dcoef, n_dcoef, t0, ts)."""
        key = (tuple(self.curves), tuple(self.curves.values()))    # (two flat tuples: half items()' cost)
        hit = getattr(self, "_table_cache", None)       # (made on first use)
        if hit is not None and hit[0] == key:
            return hit[1]
        cv = key[1]
        # (the rows as Python lists, each array made once: the same values as filling zeroed arrays)
        zero = [0.0, 0.0, 0.0, 0.0]
        coef, dcoef, n_coef, n_dcoef, poly, t0, ts = [], [], [], [], [], [], []
        for c in cv:
            p = c.s_poly
            if type(p) is Poly and len(p.coef) <= 4:
                cl, dl = p._coef_list, p._deriv._coef_list
                coef.append(cl + zero[len(cl):])
                dcoef.append(dl + zero[len(dl):])
                n_coef.append(len(cl))
                n_dcoef.append(len(dl))
                poly.append(True)
                t0.append(p.t0)
                ts.append(p.ts)
            else:
                coef.append(zero)
                dcoef.append(zero)
                n_coef.append(0)
                n_dcoef.append(0)
                poly.append(False)
                t0.append(0.0)
                ts.append(1.0)
        n = len(cv)
        table = (np.array([c.by_row for c in cv], bool), np.array([c.t_range[0] for c in cv], float),
                 np.array([c.t_range[1] for c in cv], float), np.array([c.radius_px for c in cv], float),
                 np.array(poly, bool), np.array(coef, float).reshape(n, 4), np.array(n_coef, np.int64),
                 np.array(dcoef, float).reshape(n, 4), np.array(n_dcoef, np.int64), np.array(t0, float),
                 np.array(ts, float))
        pieces = tuple(zip(*key))
        out = ({s: j for j, s in enumerate(key[0])}, pieces, table)
        self._table_cache = (key, out)
        return out

    def _hidden_crossing(self, uv: np.ndarray, s2: int, c2: BranchCurve) -> int:
        """:func:`kernels_forks.hidden_crossings`' result for one piece ``s2`` whose centre line is not
        a plain Poly (spliced past an occluder; its span already checked): numpy."""
        lo_u, lo_v = (uv.min(0) - 2).tolist()
        hi_u, hi_v = (uv.max(0) + 2).tolist()
        u0, v0, u1, v1 = self._box(s2)
        if u0 > hi_u or v0 > hi_v or u1 < lo_u or v1 < lo_v:
            return -1
        lo, hi = c2.t_range
        ta, tb = (uv[:, 1], uv[:, 0]) if c2.by_row else (uv[:, 0], uv[:, 1])
        inside = (ta >= lo - 2) & (ta <= hi + 2)
        if inside.sum() < 2:
            return -1
        f = tb - c2.s_at(ta)
        cross = (inside[:-1] & inside[1:] & (np.sign(f[:-1]) != np.sign(f[1:]))).nonzero()[0]     # (np.flatnonzero's)
        return int(cross[0]) if len(cross) else -1

