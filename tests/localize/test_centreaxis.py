"""A thick branch's row crossings' middles against its axis (localize/centreaxis.py, forkends' CENTRE_TO_AXIS;
issue 5, docs/localize-forkacc20.md): the exact silhouette of a round branch in both views."""

import math

import cv2
import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize import Localizer, forkends
from appliance.localize.centreaxis import centre_bias_px

from .shapes import ideal_rig


def silhouette_px(x_mm: float, z_mm: float, r_mm: float, f_px: float, cx_px: float) -> tuple[float, float]:
    """The image columns (px) of the two rays tangent to a vertical cylinder (axis at ``x_mm``, ``z_mm`` in
    the camera's frame, radius ``r_mm``): ``f tan(theta -+ asin(r / rho)) + cx``."""
    th, a = math.atan2(x_mm, z_mm), math.asin(r_mm / math.hypot(x_mm, z_mm))
    return f_px * math.tan(th - a) + cx_px, f_px * math.tan(th + a) + cx_px


@pytest.mark.parametrize("x_mm, z_mm, r_mm", [(0.0, 1000.0, 15.0), (300.0, 1000.0, 15.0), (-350.0, 900.0, 20.0),
                                              (200.0, 1200.0, 25.0), (400.0, 600.0, 10.0)])
def test_the_middles_of_a_round_branchs_crossings_are_moved_onto_its_axis(x_mm, z_mm, r_mm):
    f, cx, b = 1460.0, 640.0, 120.0
    l0, l1 = silhouette_px(x_mm, z_mm, r_mm, f, cx)
    r0, r1 = silhouette_px(x_mm - b, z_mm, r_mm, f, cx)
    d_centre, d_axis = 0.5 * (l0 + l1) - 0.5 * (r0 + r1), f * b / z_mm
    bias = centre_bias_px(d_centre, 0.5 * (l0 + l1), 0.5 * (l1 - l0), f, cx)
    assert abs(d_centre - bias - d_axis) < 2e-4                     # the leading order is exact here
    assert d_centre - d_axis > 0.5 * bias > 0.005                  # (and the middles are that far off)


def round_y(calib, z_mm: float, r_mm: float, x_mm: float, ss: int = 8):
    """A vertical round parent (radius ``r_mm`` at ``x_mm``, ``z_mm``) drawn in each view between its exact
    tangent rays, and a child (6 px wide) leaving it at 50 deg from the columns at row 300, at the same depth
    (drawn at the axis's disparity). Returns (left, right, left soft mask, right soft mask, the axis's disparity px)."""
    w, h = calib.image_size
    f, cx, b = calib.f_px, float(calib.P1[0, 2]), calib.baseline_mm
    d_axis = f * b / z_mm
    u_axis = f * x_mm / z_mm + cx
    imgs, masks = [], []
    for shift_mm, shift_px in ((0.0, 0.0), (b, d_axis)):
        e0, e1 = silhouette_px(x_mm - shift_mm, z_mm, r_mm, f, cx)
        j = np.arange(w, dtype=float)        # (each column's exact share between the two rays)
        share = np.clip(np.minimum(j + 0.5, e1) - np.maximum(j - 0.5, e0), 0.0, 1.0)
        big = np.zeros((h * ss, w * ss), np.uint8)
        a = math.radians(50.0)
        p0 = np.array([u_axis - shift_px, 300.0])
        p1 = p0 + 200.0 * np.array([math.sin(a), -math.cos(a)])
        cv2.line(big, tuple(int(round((v + 0.5) * ss)) for v in p0), tuple(int(round((v + 0.5) * ss)) for v in p1),
                 200, 6 * ss)
        child = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA).astype(float) / 200.0
        parent = np.zeros((h, w))
        parent[40:h - 20] = share
        grey = np.rint(40 + 160 * np.maximum(parent, child)).astype(np.uint8)
        imgs.append(cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR))
        masks.append(np.rint(255 * np.maximum(parent, child)).astype(np.uint8))      # (soft: the shares)
    return imgs[0], imgs[1], masks[0], masks[1], d_axis


def test_a_fork_on_steep_parent_sides_known_there_is_moved_by_the_parents_bias(monkeypatch):
    """The switch moves the reported fork (and nothing else) to smaller disparity by the bias of its parent's
    radius: R 30 mm at 1000 mm, 21 px at f 700, 0.075 px."""
    calib = ideal_rig(f_px=700.0)
    left, right, ml, mr, d_axis = round_y(calib, 1000.0, 30.0, 0.0)
    got = {}
    for on in (False, True):
        monkeypatch.setattr(forkends, "CENTRE_TO_AXIS", on)
        res = Localizer(calib, load_config().localize).localize(left, right, mask_left=ml, mask_right=mr)
        got[on] = {f.kind: calib.f_px * calib.baseline_mm / f.xyz_mm[2] for f in res.features}
    assert set(got[True]) == set(got[False]) == {"bifurcation", "endpoint"}
    assert got[True]["endpoint"] == got[False]["endpoint"]
    moved = got[False]["bifurcation"] - got[True]["bifurcation"]
    expect = d_axis * (21.0 / 700.0) ** 2
    assert 0.7 * expect < moved < 1.3 * expect, (moved, expect)
