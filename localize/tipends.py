"""Tips placed on the fitted branch curves (:class:`TipPlacing`, a part of :class:`ends.EndPlacer`).

A tip is where the centre line leaves the mask, one radius back (the round cap), with the disparity
of the cap's own outline; an end that the right view's outline ends elsewhere (an occluder's edge),
with something nearer just beyond it, or running out of either view, is not a tip.
"""

from __future__ import annotations

import math

import numpy as np
from appliance.localize import kernels_forkglue, kernels_match, kernels_tips
from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.capslope import MIN_SLOPE, curve_slope, slope_corrected
from appliance.localize.merged_tips import right_cap_tip, strict_round
from appliance.localize.texture import nearer_in_front
from appliance.localize.tipbark import bark_backs_run_end
from appliance.localize.tips import (CAP_EDGE_BACK, CAP_WIDTH_BACK, SPLIT_ROW_PX, VIEW_EDGE_PX, cap_centre,
                                     cap_shape, cap_shapes_offsets, occluder_confirmed, reads_round,
                                     right_flanks_filled)
from appliance.localize.walks import WALK_EDGE_BIAS

# a tip's end in the right view may lie this far (px, along the branch) from the left view's:
# steep pieces (disparity from the outline; a round cap ends on the same rectified row in both views,
# and the sub-pixel walks leave no rounding between them: 2 px with whole-pixel walks), flat pieces
# (from the texture: looser)
END_SHIFT_STEEP_PX = 1.5
END_SHIFT_FLAT_PX = 6.0

# a flat tip's right run of another length than the left's (cut or merged elsewhere along the piece
# in that view) still gives the end's disparity within this of the prior (px) if the ends agree
END_RUN_CUT_PX = 2.0

# a flat tip's run end read on the axis row that agrees (1 px) with fewer than 3 of the rows within half a radius of
# it takes the median of the rows that agree among themselves instead (a majority of at least 3 within 1 px of their
# median): one row's outline bulging in one view (seed 787's tip 4, colour masks: the right view's colour outline
# 1-3.6 px out on the axis row and its neighbour, -1.71 px; the other rows' run ends within 0.3 px of the truth)
END_ROWS_OUTVOTE = True

# a flat tip on a piece without texture (its disparity carried from its fork) keeps its run end's
# disparity only within this (px) plus this per px carried (else withheld: _carried_agrees)
CARRIED_D_PX = 2.0
CARRIED_D_PER_PX = 0.1

# a steep tip whose cap rows' two edges (both the cap's) give disparities apart by a median within
# this (px), most rows alike, has no depth of its own: one view's outline is wider by a few px all
# across the cap (a colour mask taking in background on one side); a larger split is one side
# merged with another branch in one view, which split_row_disparity resolves, and so is a smaller
# one (something touching the cap, 3 px nearer: test_a_tip_touched_on_one_side...)
CAP_SPLIT_PX = (4.0, 8.0)
CAP_SPLIT_SHARE = 0.7                    # (of the rows within 1 px of that median: all across the cap)

# a steep tip's cap none of whose rows lies within 2.5 px of the piece's disparity carried to it (the
# prior) still has a depth of its own where at least this many rows have both edges on the cap, none
# split (tips.SPLIT_ROW_PX), all within OWN_CAP_PX of their median: a round cap seen alike in both views,
# on a short piece inclined in depth whose curve does not carry its slope to the tip (seed 704's tip 14:
# a stub of 29 rows below a leaf, its curve fitted on 2 samples 12 rows back reads 177.1 px, the cap's
# 6 whole rows 173.6-174.6, the truth 174.19; the prior used to stand, -16.6 mm)
OWN_CAP_ROWS = 4
OWN_CAP_PX = 0.6

# failing that, a steep tip's cap at least this many of whose rows with an edge on the cap (one or both: a piece
# oblique to the rows shows one edge of the cap per row) lie within OWN_EDGE_PX of those rows' median, this share of
# them at least, has their median as its depth: the cap's outline seen alike in both views outvotes a prior carried
# along a piece mismatched in the right view (seed 881's tip 13, exact masks: a piece 30 deg off the rows crossing a
# branch behind it in the right view, matched 256 -> 286 px over 60 px; 18 of its 19 edge rows within 1 px of 276.81,
# the truth 276.84; the prior 286.17 stood, -20.6 mm). A single edge is noisier than a whole row's middle: 1 px.
# Only rows whose two left edges lie within OWN_EDGE_WIDTH radii (and 1 px) of the centre line count: a row whose run
# is something wider than the piece reads that thing's outline (seed 464, exact masks: a piece ending inside a trunk
# twice its width, its rows' one side the trunk's straight side, 13 rows within 0.4 px of the trunk's depth, no tip
# there: it was reported; 881 T13's rows, 30 deg off the piece, lie within 1.13 radii)
OWN_EDGE_ROWS = 8
OWN_EDGE_PX = 1.0
OWN_EDGE_SHARE = 0.8
OWN_EDGE_WIDTH = 1.5

# a piece with a tip at both ends whose two end edges lie less than this many piece radii apart is a
# blob (a branch's end seen nearly end-on): each end's outline is the silhouette of the branch behind
# it, not a cap at the tip's depth; both are withheld (seed 327's tip 11, exact masks: a 16-row stub of
# radius 6 px, 2.7 radii, each end's cap rows +2.0 / +2.2 px, -7.7 mm; seed 284's tip 4, colour masks: a
# right twig's stub 2.96 radii long, kept; 3.0 withheld it)
BLOB_STUB_WITHHELD = True
BLOB_STUB_RADII = 2.8

# a flat tip whose run end's outline does not agree row by row still takes the run end where the bark next to
# the tip reads it rather than the piece's level (tipbark.bark_backs_run_end; seed 686's tip 15, colour masks: the
# right cap touching an apple on 3 of 13 rows, the level 259.13 px, the run end 264.94, the truth 264.50)
TIP_BARK = True

# an end whose walk out along its piece's centre line never leaves the left mask within its reach (3 radii and more:
# walks.Walks._walk_out), the mask running on a radius and 1 px further (walks.Walks._walk_runs_on), is no tip: the
# branch runs on past where its skeleton piece ended, and a cap placed one radius back from the walk's last sample is
# a point on the branch's body (seed 890, exact masks: a trunk's skeleton piece ending on row 188 with the trunk
# running on down the mask, its end walked the whole reach, 81 px; the point placed lay 3 px from the true tip of a
# branch hidden behind the trunk: scored as that tip, -18.95 mm). It withheld 4 more false tips on seeds 868-899 and
# 7 / 11 (exact / colour masks) on the fifteen sets before them, no true one; without the further radius it hid seed
# 554's tip 17 (exact masks), whose cap ended half a pixel past the walk's reach
TIP_MASK_RUNS_ON = True

# a steep tip whose right view runs on past its cap into something wider (the end-shift check waived:
# TipPlacing._wider_on_right) and none of whose cap rows reads a depth (TipPlacing._cap_disparity None) is hidden:
# the right view may show only the thing in front of it (seed 723 T6, exact masks: its tip behind a nearer branch in
# the right view, the piece's line carried 21 px to it: +1.29 px, +11.9 mm)
WIDER_RIGHT_NEEDS_CAP = True

# stub31 (docs/localize-stub31.md): the same where the right view's cap merges with something beside it rather than
# past it (its end not shifted, so _wider_on_right is not asked): a steep tip none of whose cap rows reads a depth
# whose right flanks at the piece's disparity hold clearly more mask than the left's (tips.right_flanks_filled, bound
# FLANK_SHARE 0.25) is withheld. Seed 1106 T10, colour masks: a 12-row stub (r 4.7 px) whose right cap touches a
# thick trunk beside it (flank shares 0.00 left / 0.51 right), the right end 0.6 px from the left's, no cap row read;
# the short fit carried to the tip -0.74 px, +7.37 mm
WIDER_BESIDE_NEEDS_CAP = True


# a flat tip's run end (its disparity, _end_disparity) is also read on a soft mask's runs moved to the grey image's step
# whole where it is clear (within GREY_END_DEV_PX of the mask's outline: subpixel.refine_runs' whole_dev_px), as a
# binary mask's are, rather than mixed half-way between the two; that reading stands where it lies more than
# GREY_END_MIN_PX from the mixed runs': the colour recogniser's outline at a cap's end takes in part of the background
# behind it, the same way on every row of the end, and the background differs between the views (seed 942's tip 11,
# colour masks: the right cap's end over a dark leaf stalk read 0.6-0.9 px out on every row, the left over sky not,
# +1.12 px, +8.96 mm; seed 894's tip 13: the left cap's end over an apple read 1 px short). Always the grey runs' reading
# moved 29 other colour tips of 932-963 by up to 0.24 px, more away from the truth than towards it (the step alone is
# about as noisy as the colour outline: refine_runs' reason to mix them). A binary mask's runs are its own.
TIP_GREY_END = True
GREY_END_DEV_PX = 1.5
GREY_END_MIN_PX = 0.5

# fresh31 (docs/localize-fresh31.md): a flat tip on a piece whose disparity is one level (a constant: a short piece
# without a clean texture line, dense._flat_finish) and whose right run end lies within 2 px of it (taken without the
# outline checks the farther ends get) is withheld where the right view has clearly more mask beside the end than the
# left (tips.right_flanks_filled: something touches the cap in the right view only; the run end found is that thing's).
# Seed 1113 T13, colour masks: a 71 px flat twig turning in depth (its texture 137.4 -> 140.5 px over 54 px, kept as
# the constant 138.07) whose cap lies over a leaf in the right view (the colour mask joins them; the truth: the tip
# hidden there); the run end 138.01, the truth 142.16: -4.15 px, +37.19 mm; flank share difference +0.49 (bound
# FLANK_SHARE 0.25). Without the constant's condition it withheld seed 377 T11 (colour, +0.68 mm, flank +0.28: a
# 388 px texture line, its level at the tip the run end's within 0.15 px); without the right cap's (merged_tips.
# strict_round: both sides of the right view's cap at the run end within a round cap's bounds, the cap whole there:
# its end is the cap's, whatever lies beside it) seed 595 T15 (both masks, +0.36 / +0.44 mm, flank +0.32, a short
# piece's constant; 1113 T13's right cap is not round). It also withholds a false tip of seed 538 (colour masks).
FLAT_END_FLANKS_WITHHELD = True


def cap_row_scale(rows: np.ndarray, row_c: float, cy_px: float, f_px: float) -> np.ndarray:
    """Factor (N,) taking the disparity of the middle of a round cap's crossing of each rectified
    row in ``rows`` (N,) to the disparity of the cap's centre C, seen on row ``row_c``.

    A row's epipolar plane cuts the cap (a sphere around C) in a circle around the foot of C on
    that plane, and both views' crossings of the row project that circle's centre, not C: off C's
    row the foot lies nearer (or further) by the fraction ``v (v - v_C) / (1 + v^2)`` of the depth,
    ``v = (row - cy) / f`` (rows further from the image's middle row than C's are nearer). The
    principal point's row may be taken at the image's middle (a small share of the effect).
    """
    v = (np.asarray(rows, float) - cy_px) / f_px
    return 1.0 - v * (v - (row_c - cy_px) / f_px) / (1.0 + v * v)



class TipPlacing:
    """:class:`ends.EndPlacer`'s tips (its state: ``curves``, ``uvd``, ``radius``, ``hidden``, the masks
    ``sm``)."""

    def tip(self, node: int) -> None:
        """A tip: the end of the mask along the centre line, less the round cap (its own radius).

        An end is hidden, not a tip (kept as the piece's end but flagged in ``self.hidden``),
        when the right view's outline ends elsewhere along the branch than the left's (an
        occluder's edge, not the branch's own cap), or when something at the branch's depth
        or nearer lies just beyond it.
        """
        self.tips([node])

    def tips(self, nodes) -> None:
        """:meth:`tip` of several ends (each placed and checked on its own); the round-cap checks of
        the ends that reach them read the mask together (:func:`tips.cap_shapes_offsets`: each end's
        values as alone), before the probes beyond them (both only hide an end: the order does not
        matter); a tip that passes them all moves onto its cap's centre (:meth:`_place_on_cap`)."""
        ends = []
        for node in nodes:
            end = self._tip_place(node)
            if end is not None:
                ends.append((node, *end))
        if not ends:
            return
        shapes, offsets = cap_shapes_offsets(self.sm.left_mask, [end[1:4] for end in ends])
        for (node, uv_edge, out, r, edge_bias_px), shape, offset in zip(ends, shapes, offsets):
            if not reads_round(shape):            # an occluder's edge ends it (tips.cap_shape)
                self.hidden.add(int(node))
                continue
            half = max(4, int(round(r)))
            probe = uv_edge + out * (half * (abs(out[0]) + abs(out[1])) + 2)   # the square patch clear of the cap
            if nearer_in_front(self.sm.left_gray, self.sm.right_gray, probe[None], self.uvd[node][2:3],
                               np.array([half]), self.sm.d_range_px[1]) and \
                    occluder_confirmed(self.sm, uv_edge, out, self.uvd[node][2], half):
                self.hidden.add(int(node))
                continue
            self._place_on_cap(node, uv_edge, out, r, edge_bias_px, shape, offset)

    def _place_on_cap(self, node: int, uv_edge: np.ndarray, out: np.ndarray, r: float, edge_bias_px: float | None,
                      shape: list | None, offset_px: float) -> None:
        """Move a tip that passed its checks onto its round cap's centre (:func:`tips.cap_centre`,
        from the round-cap readings ``shape`` and the width's middle ``offset_px``): the cap's own
        radius (a tapering branch's piece radius ``r`` is ~10 % (p95 ~40 %) larger) back from
        where the centre line leaves the mask (the half-coverage crossing: the walk's edge
        ``uv_edge`` lies ``edge_bias_px`` past it), and across the line where the branch's width
        is not centred on it; the tip's radius becomes the cap's. Its disparity stays (the cap's
        rows, the run end). A tip whose width is read up to the view's edge keeps its place (the
        width may be cut there), and so does one the move alone would take within the features'
        edge margin (dense.match_dense: like the checks, that test sees the place it had), or a
        cap cut by the view's edge (``edge_bias_px`` None: placed from its chord)."""
        centre = None if edge_bias_px is None else cap_centre(shape, offset_px, r)
        if centre is None:
            return
        back, across, rho = centre
        # (in Python floats: numpy's element-wise steps on these 2-vectors, the same values)
        (ex, ey), (ox, oy) = uv_edge.tolist(), out.tolist()
        nx, ny = -oy, ox                                         # the normal
        k, across = float(edge_bias_px + back), float(across)       # (as numpy takes them into float64 arrays)
        uv = (ex - ox * k + nx * across, ey - oy * k + ny * across)
        kb = float(CAP_WIDTH_BACK * r)
        px, py = ex - ox * kb, ey - oy * kb
        h, w = self.sm.left_mask.shape
        for a in (shape[0][0] + offset_px, offset_px - shape[0][0]):      # the two sides (cut: last pixel + 0.5)
            a = float(a)
            sx, sy = px + a * nx, py + a * ny
            if not (sx >= 0 and sy >= 0 and sx <= w - 1 and sy <= h - 1):
                return
        margin = VIEW_EDGE_PX + self.g.scale
        old = self.uvd[node]
        if min(uv[0], uv[1], w - 1 - uv[0], h - 1 - uv[1]) < margin <= min(old[0], old[1], w - 1 - old[0], h - 1 - old[1]):
            return
        self.uvd[node][:2] = uv
        self.radius[node] = rho

    def _tip_place(self, node: int) -> tuple | None:
        """:meth:`tip` up to its round-cap check: the end placed (one piece radius back from the
        walk's edge), hidden where its checks so far say; ``(uv_edge, out, r, edge_bias_px)`` for
        the rest where it is not (yet) hidden, else None (``edge_bias_px``: how far the walk's edge
        lies past the half-coverage crossing, px; None for a cap cut by the view's edge, whose
        placement from its chord stands)."""
        segs = [s for s in self.incident[node] if s in self.curves]
        if not segs:
            return None
        c = self.curves[segs[0]]
        t_edge, sign = self._walk_out(c, node)
        sp = c.s_poly
        if type(sp) is Poly:         # (compiled: kernels_forkglue.edge_frame, the same values as below)
            lo, hi = c.t_range
            uv_edge, out, speed = kernels_forkglue.edge_frame(np.ascontiguousarray(sp.coef, float),
                                                              np.ascontiguousarray(sp._deriv.coef, float), float(sp.t0), float(sp.ts),
                                                              float(lo), float(hi), bool(c.by_row), float(t_edge),
                                                              float(sign))
        else:
            uv_edge = c.uv_at(t_edge)[0]
            step = c.uv_at(t_edge + sign)[0] - uv_edge
            speed = max(float(np.hypot(*step)), 1e-9)       # px of the image per unit of t
            out = step / speed
        r = max(c.radius_px, 1.0)
        if BLOB_STUB_WITHHELD:
            other = [n for n in self.g.seg_nodes[c.segment] if n >= 0 and n != node and len(self.incident[n]) == 1]
            t_other, sign_other = self._walk_out(c, other[0]) if other else (t_edge, sign)
            if sign_other != sign and 0.0 < abs(t_other - t_edge) * speed < BLOB_STUB_RADII * r:
                self.hidden.add(int(node))
                return None
        (ex, ey), (ox, oy) = uv_edge.tolist(), out.tolist()
        bx, by = round(ex + 2.5 * ox), round(ey + 2.5 * oy)        # (np.rint's in Python floats: halves to even)
        h, w = self.sm.left_mask.shape
        if not (0 <= bx < w and 0 <= by < h) or (self.sm.valid_left is not None and not self.sm.valid_left[by, bx]):
            back = self._cap_cut_by_edge(c, uv_edge, out, r)
            if back is None:
                return None                          # the branch leaves the view: no tip seen
            edge_bias_px = None                      # (placed from the chord: stays)
        else:
            back = r
            edge_bias_px = WALK_EDGE_BIAS * speed
        # (placed one piece radius back for the checks below; a tip that passes them all is moved
        # onto its cap's centre in tips())
        b = float(back)                          # (uv_edge - out * back in Python floats: the same values)
        u, v = ex - ox * b, ey - oy * b
        self.uvd[node] = np.array([u, v, c.d_at(v if c.by_row else u)[0]])   # (c.t_of's t)
        self.radius[node] = c.radius_px
        if TIP_MASK_RUNS_ON and self._walk_runs_on(c, node):
            self.hidden.add(int(node))          # the mask runs on past the walk's reach: no end seen (the piece's
            return None                         # end stays where placed, on the branch)
        cap_behind = False
        if not c.by_row:
            # a flat piece's disparity comes from its texture: the tip stands only if the end of
            # its row run is found in the right view too; it takes the run end's (its outline is
            # sub-pixel: subpixel.refine_runs) when the two agree (2 px) or the end's outline agrees
            # row by row
            d_end = self._end_disparity(uv_edge, out, self.uvd[node][2], r)
            if d_end is None and c.segment in self.cap_segments:
                d_end = self.uvd[node][2]     # a flat stub's curve has its cap's disparity (tips.py)
            elif d_end is None and r > 2.0:
                # the run end is this tip's only depth of its own: a centre line inclined to the
                # rows leaves the cap where the row's own run may end sooner, read it further inside
                d_end = self._end_disparity(uv_edge, out, self.uvd[node][2], r, 0.5 * r)
            if d_end is None or not self._carried_agrees(c, node, d_end):
                self.hidden.add(int(node))
                return None
            if abs(d_end - self.uvd[node][2]) <= 2.0:
                if FLAT_END_FLANKS_WITHHELD and len(c.d_poly.coef) == 1 and right_flanks_filled(
                        self.sm.left_mask, self.sm.right_mask, uv_edge, out, d_end, r) and not strict_round(
                        cap_shape(self.sm.right_mask, uv_edge - np.array([d_end, 0.0]), out, r)):
                    # the right run's end is not the cap's (something touches it there) and the piece's one level
                    # says nothing of the tip's own depth: no depth of the tip's own (seed 1113 T13)
                    self.hidden.add(int(node))
                    return None
                self.uvd[node][2] = d_end
            elif self._end_outline_agrees(uv_edge, out, d_end, r) and not right_flanks_filled(
                    self.sm.left_mask, self.sm.right_mask, uv_edge, out, d_end, r):
                # an occluder's edge lies in front of the branch it cuts: an end further away
                # than the texture says is the cap's own (the texture's is off, and so is the
                # end shift below, measured with it)
                cap_behind = d_end < self.uvd[node][2]
                self.uvd[node][2] = d_end
            elif TIP_BARK and not right_flanks_filled(self.sm.left_mask, self.sm.right_mask, uv_edge, out, d_end, r) \
                    and bark_backs_run_end(self.sm.left_gray, self.sm.right_gray, uv_edge, out, r, self.uvd[node][2],
                                           d_end, self.sm.f_px, self.sm.offset_px):
                # the outline fails on a few rows (something touching the cap in one view), but the bark next
                # to the tip reads the run end, not the piece's level: a short piece turning in depth (tipbark)
                cap_behind = d_end < self.uvd[node][2]
                self.uvd[node][2] = d_end
            # else the right run's end is not the cap's (something touches it there, along the row or
            # beside the cap: tips.right_flanks_filled): the texture's stands
        if not self._seen_right(self.uvd[node], r):
            self.hidden.add(int(node))                # hidden in the right view: no depth of its own
            return None
        # a tip ends where its 3D cap ends, in both views alike; an outline that cuts the branch
        # (a leaf, an apple, another branch at another depth) ends it elsewhere in the right view
        t_right, _ = self._walk_out(c, node, right=True)
        shifted = not cap_behind and abs(t_right - t_edge) * speed > (END_SHIFT_STEEP_PX if c.by_row else END_SHIFT_FLAT_PX)
        runs_on_right = shifted and c.by_row and sign * (t_right - t_edge) > 0 and self._wider_on_right(c, t_edge, sign, r)
        if shifted and not runs_on_right:
            # the left cap cut by a thing in front of it, whole in the right view: placed from there
            # (merged_tips.py; its own checks of the right view's cap stand for those below)
            uvd = right_cap_tip(self, c, t_edge, t_right, sign) if c.by_row else None
            if uvd is None:
                self.hidden.add(int(node))
            else:
                self.uvd[node] = uvd
            return None
        if c.by_row:        # the cap's own rows, rather than the fitted line carried to the tip
            d_cap = self._cap_disparity(c, t_edge, uv_edge, out, sign, self.uvd[node][2], r)
            if d_cap is not None and np.isnan(d_cap):
                self.hidden.add(int(node))
                return None
            if d_cap is None and runs_on_right and WIDER_RIGHT_NEEDS_CAP:
                # the right view runs on past the cap into something wider and no row of the cap reads a
                # depth near the piece's: the cap may lie behind that thing (hidden in the right view), and
                # the piece's line carried to it is no depth of the tip's own (seed 723 T6)
                self.hidden.add(int(node))
                return None
            if d_cap is None and WIDER_BESIDE_NEEDS_CAP and right_flanks_filled(
                    self.sm.left_mask, self.sm.right_mask, uv_edge, out, self.uvd[node][2], r):
                # the right view's cap merges with something beside it (its flanks filled there only) and no
                # row of the cap reads a depth: the piece's line carried to the tip is no depth of its own
                # (seed 1106 T10)
                self.hidden.add(int(node))
                return None
            if d_cap is not None:
                self.uvd[node][2] = d_cap
        if not self._beyond_in_right_view(uv_edge, out, self.uvd[node][2]):
            self.hidden.add(int(node))                # the right view's edge cuts the cap: no end seen there
            return None
        if self.cfg.oblique_end_ratio > 0:
            # a round cap ends alike on both sides of the axis; a leaf's or an apple's outline
            # usually cuts the branch obliquely (in both views alike when the leaf sits on the
            # branch): such an end is hidden, not a tip. The sides are 0.4 radius off the axis
            # (further out, a tapering tip or a radius a little too large ends a side early)
            t_a, t_b = self._walk_sides(c, node, 0.4 * r)
            if abs(t_a - t_b) * speed > self.cfg.oblique_end_ratio * r:
                t_a, t_b = self._sides_about_middle(c, node, uv_edge, out, r, sign, abs(t_a - t_b) * speed / r, (t_a, t_b))
            if abs(t_a - t_b) * speed > self.cfg.oblique_end_ratio * r:
                self.hidden.add(int(node))
                return None
        return uv_edge, out, r, edge_bias_px

    def _sides_about_middle(self, c: BranchCurve, node: int, uv_edge: np.ndarray, out: np.ndarray, r: float,
                            sign: float, split: float, sides: tuple) -> tuple:
        """The oblique test's two sides (walk parameters) read again about the middle of the
        branch's width 1.5 radii behind the end (:func:`tips.cap_shapes_offsets`) rather than the
        fitted centre line, which a fit over the whole piece often leaves 20-60 % of the radius off
        it there. On a round cap the sides 0.4 r about a line ``m`` r off its middle end
        ``sqrt(1 - (|m| - 0.4)^2) - sqrt(1 - (|m| + 0.4)^2)`` radii apart: only a ``split`` (the
        first reading, in radii) that this offset can explain, within the test's own ratio, is read
        again (an occluder's oblique edge ends the sides further apart); else ``sides`` stand."""
        mid = float(cap_shapes_offsets(self.sm.left_mask, [(uv_edge, out, r)])[1][0]) / r
        if not np.isfinite(mid) or abs(mid) > 0.6:
            return sides
        m = abs(mid)
        expected = math.sqrt(1.0 - (m - 0.4) ** 2) - math.sqrt(max(1.0 - (m + 0.4) ** 2, 0.0))
        if split > expected + self.cfg.oblique_end_ratio:
            return sides
        return (self._walk_out(c, node, sign * mid * r + 0.4 * r)[0], self._walk_out(c, node, sign * mid * r - 0.4 * r)[0])

    def _carried_agrees(self, c: BranchCurve, node: int, d_end: float) -> bool:
        """Whether a flat tip's run-end disparity ``d_end`` (px) may stand on a piece without texture.

        A flat piece whose bark gave no disparity carries its end node's (a fork's) to the tip
        (``n_samples == 0``, not a cap curve of tips.py). The run end is picked nearest that prior,
        so when the junction is two branches merely crossing in the image (another depth) the end
        found is another branch's. Such an end must lie within ``CARRIED_D_PX`` plus
        ``CARRIED_D_PER_PX`` per px the prior was carried (a branch inclined in depth); else the
        tip has no depth of its own and is withheld.
        """
        if c.n_samples > 0 or c.segment in self.cap_segments:
            return True
        others = [n for n in self.g.seg_nodes[c.segment] if n >= 0 and n != node and n in self.uvd]
        if not others:
            return True
        carried = min(float(np.hypot(*(self.uvd[n][:2] - self.uvd[node][:2]))) for n in others)
        return bool(abs(d_end - self.uvd[node][2]) <= CARRIED_D_PX + CARRIED_D_PER_PX * carried)

    def _wider_on_right(self, c: BranchCurve, t_edge: float, sign: float, r: float) -> bool:
        """Whether the right view shows a clearly wider branch just past a steep piece's left
        end, where the piece would run on (another branch touching the tip in the right view
        only, rather than the piece itself going on behind an occluder in the left view).
        """
        args = kernels_match.curve_args(c)
        if args is not None:            # compiled: the same values (kernels_match.wider_on_right)
            keys, rows, x1 = self.runs_r._find_tables
            return bool(kernels_match.wider_on_right(*args, float(t_edge), float(sign), float(r),
                                                      int(self.sm.right_mask.shape[0]), keys, rows, x1,
                                                      int(self.runs_r.width), self.runs_r.span_px))
        rows = np.rint(t_edge + sign * np.arange(1.0, max(2 * r, 4.0))).astype(int)
        rows = rows[(rows >= 0) & (rows < self.sm.right_mask.shape[0])]
        if len(rows) == 0:
            return False
        lo, hi = c.t_range
        ds = c.s_poly.deriv()(np.minimum(np.maximum(rows, lo), hi))       # (np.clip's)
        slope = float(np.hypot(1.0, ds.sum() / len(ds)))             # (the mean: np.mean's sum and division)
        ir = self.runs_r.find(rows, c.s_at(rows) - c.d_at(rows))
        wide = (ir >= 0) & (self.runs_r.span_px[np.maximum(ir, 0)] > 1.6 * 2 * r * slope + 2)
        return bool(np.count_nonzero(wide) / len(wide) >= 0.8)

    def _cap_cut_by_edge(self, c: BranchCurve, uv_edge: np.ndarray, out: np.ndarray, r: float) -> float | None:
        """A steep piece that runs to the edge of the view: the distance (px) from its last
        row back to the centre of its round cap when the cap's chord there is clearly narrower
        than the branch (the cap is cut by the edge); None when the branch runs on out of view.
        """
        if not c.by_row:
            return None
        inner = uv_edge - out
        row = int(np.rint(inner[1]))
        if not 0 <= row < self.sm.left_mask.shape[0]:
            return None
        i = self.runs_l.find(np.array([row]), np.array([inner[0]]))[0]
        if i < 0:
            return None
        chord = self.runs_l.span_px[i] * abs(out[1])
        if chord >= 1.6 * r:
            return None
        return 1.0 + float(np.sqrt(r * r - 0.25 * chord * chord))

    def _cap_disparity(self, c: BranchCurve, t_edge: float, uv_edge: np.ndarray, out: np.ndarray, sign: float,
                       d_prior: float, r: float) -> float | None:
        """Disparity of a steep piece's tip from the rows across its round cap.

        Each rectified row cuts the cap (a sphere around the centre ``P``, one radius back from
        the end along the centre line) in a circle; the middles of the left and right crossings
        of that row both project that circle's centre, a point within the cap, whose depth
        :func:`cap_row_scale` takes back to the cap's centre. Only the cap's own outline counts:
        a crossing's edge is the cap's where it lies on the outward side of ``P`` (across the
        centre line through ``P``); behind it the outline is the piece's body, whose depth is
        another (on an oblique piece one edge of a row is the cap's and the other the body's).
        A row with both edges on the cap gives its middle, a row with one its edge's disparity
        less the outline's silhouette offset (:func:`tips.silhouette_offset_px`, for the row's
        circle), and a row whose edges disagree (:func:`tips.split_row_disparity`: one cut or
        merged in one view only) the nearest of the two and the middle to the agreeing rows. A
        run ending at the view's edge gives no edge there. Median over the rows, within 2.5 px
        of ``d_prior``; with fewer than 3 such rows, the median of the rows with both edges on the
        cap where they agree among themselves (``OWN_CAP_ROWS``, ``OWN_CAP_PX``: the cap's own depth,
        off a prior carried along a short piece inclined in depth); else None. ``uv_edge``, ``out``: where the centre line
        leaves the mask (at ``t_edge``) and its unit direction there (:meth:`_tip_place`'s). Failing those, the
        median of the cap's edge rows agreeing among themselves (``OWN_EDGE_ROWS``: rows of the piece's own width).
        """
        sm = self.sm
        h, w = sm.left_mask.shape
        p = uv_edge - out * r                                # the cap's centre (the tip)
        a = max(int(np.ceil(min(p[1] - r, t_edge))), 0)
        b = min(int(np.floor(max(p[1] + r, t_edge))), h - 1)
        rows = np.arange(a, b + 1)
        rows = rows[(np.abs(rows - p[1]) <= r) & (sign * (t_edge - rows) >= -0.5)]
        if len(rows) < 3:
            return None
        # (the rows' runs, edges, silhouette offsets, split rows and median: one kernel)
        rl, rr, valid_l, valid_r = TipPlacing._tip_tables(self)
        status, d = kernels_tips.cap_disparity(rows, c.s_at(rows), rl, rr, valid_l, valid_r, float(p[0]), float(p[1]),
                                               float(out[0]), float(out[1]), float(r), float(d_prior), float(sm.f_px),
                                               h, w, CAP_EDGE_BACK, SPLIT_ROW_PX, *CAP_SPLIT_PX, CAP_SPLIT_SHARE,
                                               OWN_CAP_ROWS, OWN_CAP_PX, OWN_EDGE_ROWS, OWN_EDGE_PX, OWN_EDGE_SHARE,
                                               OWN_EDGE_WIDTH)
        if status != 1:
            return None if status == 0 else float(d)
        return self._cap_slope_corrected(c, float(d), t_edge, uv_edge, out, sign, r)

    def _cap_slope_corrected(self, c: BranchCurve, d: float, t_edge: float, uv_edge: np.ndarray, out: np.ndarray,
                             sign: float, r: float) -> float:
        """:meth:`_cap_disparity`'s reading ``d`` taken back to the cap's own centre on a piece inclined
        in depth (:func:`capslope.slope_corrected`: the rows between the piece radius' ``P`` and the
        cap's centre, read from its own width by :func:`tips.cap_centre`, cross the body)."""
        px_per_t = 1.0 / max(abs(float(out[1])), 1e-6)          # (a steep piece: t is the row)
        slope = curve_slope(c.d_at, t_edge, c.t_range, sign, r, px_per_t)
        if slope is None or abs(slope) < MIN_SLOPE:
            return d
        shapes, offsets = cap_shapes_offsets(self.sm.left_mask, [(uv_edge, out, r)])
        centre = cap_centre(shapes[0], float(offsets[0]), r)
        if centre is None:
            return d
        return slope_corrected(d, slope, r, WALK_EDGE_BIAS * px_per_t + centre[0])

    def _tip_tables(self) -> tuple:
        """The mask runs' and the valid areas' tables the tips' kernels take (:func:`kernels_tips.runs_tables`),
        made once per placer (again if its runs are replaced)."""
        # (read through getattr: the tests' stand-in placers and masks carry only what they use)
        hit = self.__dict__.get("_tip_k")
        sm = self.sm
        if hit is not None:
            k = hit[0]
            if k[0] is self.runs_l and k[1] is self.runs_r and k[2] is getattr(sm, "valid_left", None) \
                    and k[3] is getattr(sm, "valid_right", None):
                return hit[1]
        key = (self.runs_l, self.runs_r, getattr(sm, "valid_left", None), getattr(sm, "valid_right", None))
        hit = self._tip_k = (key, (kernels_tips.runs_tables(key[0]), kernels_tips.runs_tables(key[1]),
                                   kernels_tips.valid_table(key[2]), kernels_tips.valid_table(key[3])))
        return hit[1]

    def _beyond_in_right_view(self, uv_edge: np.ndarray, out: np.ndarray, d: float) -> bool:
        """Whether the right view sees the pixel just past the cap's end (``uv_edge``, left px, moved by
        disparity ``d``) along its row: a cap whose end lies at or past the right view's left or right
        edge shows there only the edge, whatever rows are read. (A cap cut by the top or bottom edge
        is cut on the same rows in both views: the rows left still give its disparity.)"""
        (ex, ey), (ox, oy) = uv_edge.tolist(), out.tolist()
        fu, fv = ex + ox - float(d), ey + oy - 0.0        # (uv_edge + out - [d, 0] in Python floats)
        if not math.isfinite(fu):
            return False                 # (np.rint(nan).astype(int) is INT_MIN: not inside [0, w) either)
        u, v = round(fu), round(fv) if math.isfinite(fv) else 0     # (np.rint's: halves to even; INT_MIN -> row 0)
        h, w = self.sm.right_mask.shape
        if not 0 <= u < w:
            return False
        valid = self.sm.valid_right
        if valid is None:
            return True
        row = valid[min(max(v, 0), h - 1)]
        return bool(row[u]) or not row.any()

    def _seen_right(self, uvd: np.ndarray, r: float) -> bool:
        """Whether the right mask has branch within half a radius of the point's right position."""
        m = self.sm.right_mask
        u, v = float(uvd[0] - uvd[2]), float(uvd[1])          # (Python floats: round() halves to even, as numpy)
        k = max(1, int(round(0.5 * r)))
        y0, y1 = round(v) - k, round(v) + k + 1
        x0, x1 = round(u) - k, round(u) + k + 1
        if y0 < 0 or x0 < 0 or y1 > m.shape[0] or x1 > m.shape[1]:
            return False
        return bool(m[y0:y1, x0:x1].max() >= 128)

    def _end_disparity(self, uv_edge: np.ndarray, out: np.ndarray, d_prior: float, r: float = 0.0,
                       inside_px: float = 1.0) -> float | None:
        """Disparity of the end of a flat piece: the end of its row run in both views.

        The round cap's silhouette ends one image radius beyond the cap centre in both views, so the run ends
        are corresponding points. Right runs of a similar length ending in the disparity range are candidates;
        the one nearest ``d_prior`` wins. With the radius ``r`` (px), the median over the rows within half a
        radius of the axis (at least 3 within 1 px of the axis row's): on 28 rendered scenes the median error of
        such tips drops by a third to a half (docs/localize-subpixel.md). Where the axis row's end agrees with
        fewer than 3 of those rows (``END_ROWS_OUTVOTE``), the median of the rows that agree among themselves (a
        majority of at least 3 within 1 px of their median; a right run the axis row's end misses is read a radius
        inside): one row's outline bulging in one view does not set the end. The row's left run is the one ``inside_px`` back along
        the row from ``uv_edge``. With a soft mask's runs on the grey step (``TIP_GREY_END``) their reading stands
        where it differs from this one by over ``GREY_END_MIN_PX``.
        """
        sm = self.sm
        h, w = sm.left_mask.shape
        rl, rr, _, valid_r = TipPlacing._tip_tables(self)
        args = (float(uv_edge[0]), float(uv_edge[1]), float(out[0]), float(out[1]), float(d_prior), float(r),
                float(inside_px), float(sm.d_range_px[0]), float(sm.d_range_px[1]), float(sm.f_px), h, w,
                END_RUN_CUT_PX, END_ROWS_OUTVOTE)
        ok, d = kernels_tips.end_disparity(rl, rr, valid_r, *args)
        grey = self.__dict__.get("runs_grey_end")
        if ok and grey is not None:         # (TIP_GREY_END: a soft mask's runs on the grey step)
            hit = self.__dict__.get("_grey_k")
            if hit is None or hit[0] is not grey:
                hit = self._grey_k = (grey, (kernels_tips.runs_tables(grey[0]), kernels_tips.runs_tables(grey[1])))
            ok_g, d_g = kernels_tips.end_disparity(*hit[1], valid_r, *args)
            if ok_g and abs(d_g - d) > GREY_END_MIN_PX:
                d = d_g
        return float(d) if ok else None

    def _end_outline_agrees(self, uv_edge: np.ndarray, out: np.ndarray, d: float, r: float) -> bool:
        """Whether a flat piece's end has the same outline in both views at disparity ``d``.

        On the rows across the end (0.6 radius each side of the centre line) the left run's end
        and the right run's end (moved by ``d``) must agree within 1.2 px on at least 80 % of at
        least 3 rows: a round cap ends alike in both views; a right run that runs on into
        something touching the cap (another branch) ends elsewhere on some rows.
        """
        rl, rr, _, _ = TipPlacing._tip_tables(self)
        return bool(kernels_tips.end_outline_agrees(rl, rr, float(uv_edge[0]), float(uv_edge[1]), float(out[0]), float(d),
                                                    float(r), self.sm.left_mask.shape[0]))

