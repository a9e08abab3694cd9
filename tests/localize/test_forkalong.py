"""A fork whose child lies along its parent, placed from the merged silhouette (appliance.localize.forkalong)."""

import cv2
import numpy as np
import pytest
from appliance.localize import forkalong
from appliance.localize.forkalong import along_fork, sections

SS = 4


def _px(p):
    return int(round((p[0] + 0.5) * SS - 0.5)), int(round((p[1] + 0.5) * SS - 0.5))


def _along_mask(angle_deg: float, r_par: float = 10.0, r_child: float = 6.0, fork=(150.0, 200.0),
                tilt_deg: float = 4.0, size=(300, 500), child_len: float = 300.0, binary: bool = False):
    """A mask (H x W, soft 0-255 unless ``binary``) of a straight parent along the rows (tilted ``tilt_deg``)
    with a child leaving it at ``angle_deg`` from ``fork``; returns (mask, fork, parent dir, child dir)."""
    h, w = size
    f = np.asarray(fork, float)
    t = np.radians(tilt_deg)
    e_par = np.array([np.cos(t), np.sin(t)])
    a = t - np.radians(angle_deg)
    e_ch = np.array([np.cos(a), np.sin(a)])
    big = np.zeros((h * SS, w * SS), np.uint8)
    cv2.line(big, _px(f - 400 * e_par), _px(f + 600 * e_par), 255, int(round(2 * r_par * SS)))
    cv2.line(big, _px(f), _px(f + child_len * e_ch), 255, int(round(2 * r_child * SS)))
    grey = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
    return (((grey >= 128) * 255).astype(np.uint8) if binary else grey), f, e_par, e_ch


def _junction(f, e_par, e_ch, angle_deg, r_par=10.0, r_child=6.0):
    """Where a skeleton junction forms: a few px past the child's inner outline leaving the parent's, on a
    parent line pulled 3 px towards the child."""
    a = np.radians(angle_deg)
    s_part = (r_par + r_child / np.cos(a)) / np.tan(a) + 5.0
    n = np.array([-e_par[1], e_par[0]])
    n = n if np.dot(n, e_ch) > 0 else -n
    return f + s_part * e_par + 3.0 * n


@pytest.mark.parametrize("angle_deg", [15.0, 20.0, 30.0])
@pytest.mark.parametrize("binary", [False, True])
def test_a_child_along_its_parent_is_placed_where_the_axes_meet(angle_deg, binary):
    # the junction lies 50-90 px past the fork; the child's outer outline next to the widening's onset and its
    # width past the parting place the fork within 1.5 px
    mask, f, e_par, e_ch = _along_mask(angle_deg, binary=binary)
    p = _junction(f, e_par, e_ch, angle_deg)
    assert np.hypot(*(p - f)) > 30.0
    hit = along_fork(mask, p, e_par, e_ch, 10.0, 6.0)
    assert hit is not None
    xy, c_ax, e_ax = hit
    assert np.hypot(*(xy - f)) < 1.5
    # the line returned is the parent's axis
    n = np.array([-e_ax[1], e_ax[0]])
    assert abs(np.dot(f - c_ax, n)) < 0.5
    assert abs(np.dot(e_ax, e_par)) > np.cos(np.radians(0.5))


def test_a_child_whose_own_radius_disagrees_is_not_placed():
    # the child measured past the parting is 6 px; told 12 px, the construction withholds
    mask, f, e_par, e_ch = _along_mask(20.0)
    p = _junction(f, e_par, e_ch, 20.0)
    assert along_fork(mask, p, e_par, e_ch, 10.0, 6.0) is not None
    assert along_fork(mask, p, e_par, e_ch, 10.0, 12.0) is None


def test_a_branch_bent_away_past_the_onset_is_not_placed():
    # a child leaving at 15 deg that turns to 35 deg 20 px past where it leaves the parent's outline: the outer
    # outline next to the onset and the child's run past the parting disagree in angle
    angle = 15.0
    mask, f, e_par, e_ch = _along_mask(angle, child_len=40.0)
    big = cv2.resize(mask, (mask.shape[1] * SS, mask.shape[0] * SS), interpolation=cv2.INTER_NEAREST)
    knee = f + 40.0 * e_ch
    a2 = np.radians(4.0 - 35.0)
    cv2.line(big, _px(knee), _px(knee + 250.0 * np.array([np.cos(a2), np.sin(a2)])), 255, int(round(12 * SS)))
    mask = cv2.resize(big, (mask.shape[1], mask.shape[0]), interpolation=cv2.INTER_AREA)
    p = knee + 20.0 * np.array([np.cos(a2), np.sin(a2)])
    p = f + np.dot(p - f, e_par) * e_par
    assert along_fork(mask, p, e_par, e_ch, 10.0, 6.0) is None


def test_a_thin_parent_is_not_read():
    # a parent of radius 6 px (its widening's 1.5 px a quarter of its radius): withheld, though the geometry holds
    mask, f, e_par, e_ch = _along_mask(20.0, r_par=6.0, r_child=4.0)
    p = _junction(f, e_par, e_ch, 20.0, r_par=6.0, r_child=4.0)
    diag = {}
    assert along_fork(mask, p, e_par, e_ch, 6.0, 4.0, diag) is None
    assert diag["why"] == "a thin parent"


def test_outside_the_angles_read_nothing_is_placed():
    mask, f, e_par, e_ch = _along_mask(20.0)
    p = _junction(f, e_par, e_ch, 20.0)
    steep = np.array([np.cos(np.radians(4.0 - 70.0)), np.sin(np.radians(4.0 - 70.0))])
    diag = {}
    assert along_fork(mask, p, e_par, steep, 10.0, 6.0, diag) is None
    assert "MAX_DEG" in diag["why"]


def test_sections_read_the_runs_ends_to_a_fraction_of_a_pixel():
    # a band 20 px wide along the rows, its edges at y = 100 +- 10 (pixel centres), a second band beyond
    mask = np.zeros((200, 200), np.uint8)
    mask[90:111, :] = 255                       # rows 90..110: coverage half at 89.5 and 110.5
    mask[120:131, :] = 255
    s = np.arange(-20.0, 21.0)
    t = np.arange(-20.0, 40.0)
    sec = sections(mask, np.array([100.0, 100.0]), np.array([1.0, 0.0]), np.array([0.0, 1.0]), s, t, 15.0)
    assert sec["ok"].all() and sec["child"].all()
    np.testing.assert_allclose(sec["lo"], -10.5 + 0.0, atol=0.51)
    np.testing.assert_allclose(sec["hi"] - sec["lo"], 21.0, atol=0.05)
    np.testing.assert_allclose(sec["ch"] - sec["cl"], 11.0, atol=0.05)
    # ... and no child run further than the gap allowed
    far = sections(mask, np.array([100.0, 100.0]), np.array([1.0, 0.0]), np.array([0.0, 1.0]), s, t, 5.0)
    assert not far["child"].any()


def test_the_angle_limits_are_the_modules():
    assert forkalong.MIN_DEG < 15.0 < forkalong.MAX_DEG


def _shifted_mask(angle_deg: float, d_par: float, d_child: float):
    """The right view of ``_along_mask(angle_deg)``: the parent moved by ``d_par`` px along the rows, the child by
    ``d_child`` (a child at another depth where they differ)."""
    h, w = 300, 500
    f = np.array([150.0, 200.0])
    t = np.radians(4.0)
    e_par = np.array([np.cos(t), np.sin(t)])
    a = t - np.radians(angle_deg)
    e_ch = np.array([np.cos(a), np.sin(a)])
    big = np.zeros((h * SS, w * SS), np.uint8)
    fp, fc = f - np.array([d_par, 0.0]), f - np.array([d_child, 0.0])
    cv2.line(big, _px(fp - 400 * e_par), _px(fp + 600 * e_par), 255, int(round(20 * SS)))
    cv2.line(big, _px(fc), _px(fc + 300 * e_ch), 255, int(round(12 * SS)))
    return cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)


@pytest.mark.parametrize("d_child, agrees", [(20.0, True), (26.0, False)])
def test_the_right_view_confirms_a_child_at_the_parents_depth_only(d_child, agrees):
    # ForkPlacing._along_agrees: the right view's construction (the junction moved by the fork's disparity, 20 px)
    # places the fork at the left place moved by it when the child lies at the parent's depth; a child 6 px of
    # disparity nearer leaves the parent's outline ~20 px further along it
    from types import SimpleNamespace

    from appliance.localize.forkends import ForkPlacing

    angle = 20.0
    left, f, e_par, e_ch = _along_mask(angle)
    p = _junction(f, e_par, e_ch, angle)
    xy = along_fork(left, p, e_par, e_ch, 10.0, 6.0)[0]
    placer = SimpleNamespace(sm=SimpleNamespace(right_mask=_shifted_mask(angle, 20.0, d_child)))
    assert ForkPlacing._along_agrees(placer, xy, p, e_par, e_ch, 20.0, 10.0, 6.0) is agrees


def test_polyfit_line_is_numpys_polyfit():
    """The sections' line fits: np.polyfit's slope and intercept bit for bit (section indices and random
    abscissae, noisy lines, 3-250 points)."""
    from appliance.localize.forkalong import polyfit_line
    rng = np.random.default_rng(3)
    for i in range(400):
        n = int(rng.integers(3, 250))
        x = np.arange(n, dtype=float) - float(rng.integers(0, 200)) if i % 2 else rng.uniform(-200, 200, n)
        y = rng.normal(0, 5, n) + rng.uniform(-1, 1) * x + rng.uniform(-100, 100)
        k, a = np.polyfit(x, y, 1)
        assert polyfit_line(x, y) == (float(k), float(a))
