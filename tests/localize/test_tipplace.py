"""Where a tip is placed along its branch: the cap's own radius (appliance.localize.tips.cap_radius /
cap_centre, used by appliance.localize.ends.EndPlacer.tips), on tapering rods drawn anti-aliased."""

import cv2
import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.localize.tips import cap_centre, cap_radius, cap_shapes_offsets

from .shapes import ideal_rig

CFG = load_config().localize


def _round_cone_cover(shape, base, tip, r_base, r_tip, ss=6):
    """Share (H, W) of each pixel inside the 2D round cone (hull of the discs ``(base, r_base)`` and
    ``(tip, r_tip)``: a tapering branch with a round cap), from ``ss`` x ``ss`` samples per pixel
    near it (pixel centres at integers; Inigo Quilez's uneven capsule)."""
    h, w = shape
    cover = np.zeros((h, w))
    rr = max(r_base, r_tip)
    x0, x1 = max(int(min(base[0], tip[0]) - rr - 2), 0), min(int(max(base[0], tip[0]) + rr + 3), w)
    y0, y1 = max(int(min(base[1], tip[1]) - rr - 2), 0), min(int(max(base[1], tip[1]) + rr + 3), h)
    off = (np.arange(ss) + 0.5) / ss - 0.5
    ys = (np.arange(y0, y1)[:, None] + off[None, :]).ravel()
    xs = (np.arange(x0, x1)[:, None] + off[None, :]).ravel()
    px, py = np.meshgrid(xs, ys)
    axis = np.subtract(tip, base, dtype=float)
    length = float(np.hypot(*axis))
    axis /= length
    ly = (px - base[0]) * axis[0] + (py - base[1]) * axis[1]
    lx = np.abs(-(px - base[0]) * axis[1] + (py - base[1]) * axis[0])
    b = (r_base - r_tip) / length
    a = np.sqrt(1.0 - b * b)
    k = -b * lx + a * ly
    dist = np.where(k < 0.0, np.hypot(lx, ly) - r_base,
                    np.where(k > a * length, np.hypot(lx, ly - length) - r_tip, a * lx + b * ly - r_base))
    cover[y0:y1, x0:x1] = (dist <= 0).reshape(y1 - y0, ss, x1 - x0, ss).mean(axis=(1, 3))
    return cover


def test_a_tapering_rods_cap_radius_is_its_own_not_the_pieces():
    # radius 12 px at the base, 6 px at the tip over 300 px: the piece's median radius (~9 px)
    # is half as large again as the cap's; the width read 1.5 such radii behind the end is the
    # cap's within a few tenths of a pixel (soft masks; binary ones to their whole pixels)
    tip, r_tip = (300.0, 60.3), 6.0
    cover = _round_cone_cover((420, 600), (300.0, 360.3), tip, 12.0, r_tip)
    up = np.array([0.0, -1.0])
    edge = np.array([tip[0], tip[1] - r_tip])
    for mask, tol in ((np.rint(255 * cover).astype(np.uint8), 0.35), ((cover >= 0.5).astype(np.uint8) * 255, 0.6)):
        rho = cap_radius(mask, edge, up, 9.0)
        assert rho is not None and abs(rho - r_tip) < tol        # (binary: whole pixels across)
        # an end read from a point off the mask, or a reading far off the piece's radius: none
        assert cap_radius(mask, edge + (40.0, 0.0), up, 9.0) is None
        assert cap_radius(mask, edge, up, 30.0) is None


def test_a_touched_caps_radius_is_its_free_sides_reach():
    # a bar touching the cap's right side runs on past the end: the mean of the two sides would be
    # ~4 px too large; the free side's reach from the centre line is the radius
    tip, r_tip = (300.0, 60.3), 6.0
    mask = np.rint(255 * _round_cone_cover((420, 600), (300.0, 360.3), tip, 12.0, r_tip)).astype(np.uint8)
    cv2.rectangle(mask, (int(tip[0] + r_tip - 1), 20), (int(tip[0] + r_tip + 8), 90), 255, -1)
    rho = cap_radius(mask, np.array([tip[0], tip[1] - r_tip]), np.array([0.0, -1.0]), 9.0)
    assert rho is not None and abs(rho - r_tip) < 0.5


def test_a_cap_centre_off_the_fitted_line_is_found_across_it():
    # a centre line fitted 2 px to the right of the rod's axis leaves the cap's outline
    # sqrt(r^2 - 2^2) beyond the centre's foot on it: the centre is that far back and 2 px across
    tip, r_tip = (300.0, 60.3), 6.0
    mask = np.rint(255 * _round_cone_cover((420, 600), (300.0, 360.3), tip, 12.0, r_tip)).astype(np.uint8)
    up = np.array([0.0, -1.0])
    edge = np.array([302.0, tip[1] - np.sqrt(r_tip ** 2 - 4.0)])
    shapes, offsets = cap_shapes_offsets(mask, [(edge, up, 9.0)])
    back, across, rho = cap_centre(shapes[0], float(offsets[0]), 9.0)
    centre = edge - up * back + np.array([-up[1], up[0]]) * across
    assert np.hypot(*(centre - tip)) < 0.35 and abs(rho - r_tip) < 0.35


# the drawn right view is the left one moved along the rows (see test_tipd: a long focal length and
# a short baseline make a real round outline's perspective negligible)
RIG = dict(f_px=3000.0, baseline_mm=20.0)


@pytest.mark.parametrize("base_x", [300.0, 440.0])
def test_a_tapering_branchs_tip_is_its_caps_centre(base_x):
    # a branch tapering from 12 px to 6 px at its tip (upright or ~20 deg off): the tip is placed
    # at the end sphere's centre (it was ~3 px back, one piece radius from the walk's edge) and
    # reports the cap's radius, not the piece's
    calib = ideal_rig(**RIG)
    z_mm = 900.0
    d_tip = calib.f_px * calib.baseline_mm / z_mm
    tip, base, r_tip, r_base = (300.0, 90.0), (base_x, 440.0), 6.0, 12.0
    w, h = calib.image_size
    views = []
    for dt, db in ((0.0, 0.0), (d_tip, d_tip + 20.0)):
        cover = _round_cone_cover((h, w), (base[0] - db, base[1]), (tip[0] - dt, tip[1]), r_base, r_tip)
        g = np.rint(40 + 160 * cover).astype(np.uint8)
        views += [cv2.cvtColor(g, cv2.COLOR_GRAY2BGR), (cover >= 0.5).astype(np.uint8) * 255]
    left, ml, right, mr = views
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = [f for f in res.features if f.kind == "endpoint" and f.left_px[1] < 200]
    assert len(tips) == 1
    assert np.hypot(*np.subtract(tips[0].left_px, tip)) <= 0.6
    r_px = tips[0].radius_mm * calib.f_px / z_mm
    assert abs(r_px - r_tip) <= 0.6
