"""The surface-to-axis step of the flat pieces' texture disparity on a drawn textured cylinder."""

import numpy as np
import pytest
from appliance.localize.texture import (
    axis_to_surface,
    patch_depth_fraction,
    slant_depth_factor,
    surface_disparity,
    surface_to_axis,
)
from appliance.synth.raycast import round_cone

F_PX, B_MM, CX, CY, W, H = 1450.0, 120.0, 450.0, 120.0, 900, 240


def _draw(p0: np.ndarray, axis: np.ndarray, r_mm: float, origin_x_mm: float) -> np.ndarray:
    """A rectified view (H, W) uint8 of a long cylinder with bark-like texture, camera at x = origin_x_mm
    (2 x 2 samples a pixel)."""
    rng = np.random.default_rng(5)
    k = rng.uniform(0.6, 2.5, 24)                     # texture waves along the axis (rad/mm)
    m = rng.integers(-12, 13, 24)                     # ... and around it (whole turns)
    ph = rng.uniform(0, 2 * np.pi, 24)
    o = np.array([origin_x_mm, 0.0, 0.0])
    e1 = np.cross(axis, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    img = np.zeros((H, W))
    for sy in (0.25, 0.75):
        for sx in (0.25, 0.75):
            u, v = np.meshgrid(np.arange(W) - 0.5 + sx, np.arange(H) - 0.5 + sy)
            d = np.stack([(u - CX) / F_PX, (v - CY) / F_PX, np.ones_like(u)], -1)
            d /= np.linalg.norm(d, axis=-1, keepdims=True)
            t = round_cone(o, d, p0 - 1000 * axis, p0 + 1000 * axis, r_mm, r_mm)
            hit = np.isfinite(t)
            q = o + d[hit] * t[hit][:, None] - p0
            s, phi = q @ axis, np.arctan2(q @ e2, q @ e1)
            tex = np.sin(np.outer(s, k) + np.outer(phi, m) + ph).sum(1)
            shade = 0.4 + 0.6 * np.clip(-(d[hit] * (q - np.outer(s, axis))).sum(1) / r_mm, 0, 1)
            val = np.full(u.shape, 30.0)
            val[hit] = 120 + shade * 12 * tex
            img += val / 4
    return np.clip(img, 0, 255).astype(np.uint8)


def _axis_px(p0, axis, u_px):
    """Left-view row and disparity of the axis point projecting to column ``u_px`` (N,)."""
    # the point p0 + s axis projects to u = CX + F x / z: solve for s
    s = ((u_px - CX) * p0[2] - F_PX * p0[0]) / (F_PX * axis[0] - (u_px - CX) * axis[2])
    p = p0 + np.outer(s, axis)
    return CY + F_PX * p[:, 1] / p[:, 2], F_PX * B_MM / p[:, 2]


@pytest.mark.parametrize("slant_deg", [0.0, 20.0])
def test_texture_disparity_lands_on_the_axis_of_a_thick_slanted_cylinder(slant_deg):
    b = np.radians(slant_deg)
    axis = np.array([np.cos(b), 0.03, np.sin(b)])
    axis /= np.linalg.norm(axis)
    p0, r_mm = np.array([60.0, 0.0, 600.0]), 8.0
    left, right = _draw(p0, axis, r_mm, 0.0), _draw(p0, axis, r_mm, B_MM)
    u = np.arange(500.0, 741.0, 12.0)
    v, d_true = _axis_px(p0, axis, u)
    r_px = F_PX * r_mm / (F_PX * B_MM / d_true)      # the image radius at each patch
    hh = max(1, int(0.6 * np.median(r_px)))
    uv = np.column_stack([u, v])
    d_surf, score = surface_disparity(left, right, uv, np.full(len(u), hh), (d_true.min() - 8, d_true.max() + 12),
                                      half_w_px=12)
    assert (score > 0.8).all()
    whole_radius = surface_to_axis(d_surf, r_px, F_PX, depth_fraction=1.0) - d_true
    dv = np.gradient(v, u)
    k = patch_depth_fraction(float(np.median(r_px)), hh, dv)
    assert 0.9 < k.min() <= k.max() < 0.96                  # rows +-0.6 radius: 0.94 radius in front of the axis
    slope = np.polyfit(u, d_surf, 1)[0]
    g = slant_depth_factor(u, v, d_true, slope, dv, F_PX, (CX, CY))
    ray = np.column_stack([(u - CX) / F_PX, (v - CY) / F_PX, np.ones_like(u)])
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)                   # to the axis points
    assert g == pytest.approx(ray[:, 2] / np.sqrt(1 - (ray @ axis) ** 2), rel=0.02)
    assert g.min() >= 0.99 and (slant_deg == 0 or g.mean() > 1.05)
    ours = surface_to_axis(d_surf, r_px, F_PX, depth_fraction=k * g) - d_true
    assert abs(np.median(ours)) < 0.12
    # the old step (one whole radius along the optical axis) was off: too far at 0 deg (-0.15 px), too
    # near at 20 deg (+0.25 px; 25 deg: +0.5, 35 deg: +1.07, where ours is within 0.15)
    assert abs(np.median(whole_radius)) > abs(np.median(ours)) + 0.05
    assert np.percentile(np.abs(ours), 90) < 0.25


def test_patch_depth_fraction_is_the_mean_surface_offset():
    assert patch_depth_fraction(10.0, 0) == pytest.approx(1.0)
    y = np.arange(-6, 7) / 10.0
    assert patch_depth_fraction(10.0, 6) == pytest.approx(np.sqrt(1 - y * y).mean())
    # a branch at 45 deg to the rows: the rows cross it 1/cos(45) longer, the offsets across it shorter
    assert patch_depth_fraction(10.0, 6, np.array([1.0]))[0] > patch_depth_fraction(10.0, 6)
    assert surface_to_axis(np.array([100.0]), 10.0, 1000.0)[0] == pytest.approx(
        100.0 / (1 + patch_depth_fraction(10.0, 6) * 0.01))


def test_axis_to_surface_inverts_surface_to_axis_and_lies_nearer():
    d_axis = np.array([120.0, 180.0, 240.0])
    d_surf = axis_to_surface(d_axis, 9.0, F_PX, 3.0, 0.8)
    assert np.all(d_surf > d_axis)                  # the surface is in front of the axis: nearer, more disparity
    np.testing.assert_allclose(surface_to_axis(d_surf, 9.0, F_PX, 3.0, 0.8), d_axis, rtol=0, atol=1e-12)
    assert isinstance(axis_to_surface(150.0, 9.0, F_PX, 3.0, 0.8), float)     # a scalar stays a scalar
