"""synth/scene.py's kept supersample rays (``_rays``): computed once per rig, side and supersampling, shared
read-only by every render, and a render from kept rays is byte-identical to one that computes them."""

import numpy as np

from appliance.synth import scene
from appliance.synth.rig import Rig, default_rig


def small_rig(T=None) -> Rig:
    r = default_rig()
    s = np.diag([0.25, 0.25, 1.0])
    return Rig(s @ r.K1, r.D1, s @ r.K2, r.D2, r.R, r.T if T is None else T, 320, 240)


def test_the_rays_of_a_rig_are_kept_read_only_and_equal_to_computing_them():
    scene._RAYS.clear()
    a = scene._rays(small_rig(), "right", 2)
    assert scene._rays(small_rig(), "right", 2) is a          # another Rig object of the same values
    assert not a.dirs.flags.writeable and not a.origin.flags.writeable
    assert a.dirs.shape == (480, 640, 3) and a.dirs.dtype == np.float32
    grid = small_rig().normalised_grid("right", 2)
    d = np.concatenate([grid, np.ones(grid.shape[:2] + (1,))], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    assert np.array_equal(a.dirs, (d @ small_rig().R).astype(np.float32))
    assert np.array_equal(a.colmin, grid[..., 0].min(0)) and np.array_equal(a.rowmax, grid[..., 1].max(1))
    moved = scene._rays(small_rig(T=np.array([-100.0, 0.5, 0.9])), "right", 2)   # another pose: its own rays
    assert moved is not a and not np.array_equal(moved.origin, a.origin)
    assert scene._rays(small_rig(), "right", 1).dirs.shape == (240, 320, 3)       # another supersampling
    for ss in (3, 4, 5):                                      # only the last few are kept
        scene._rays(small_rig(), "left", ss)
    assert len(scene._RAYS) == scene._RAYS_KEPT and scene._rays(small_rig(), "right", 2) is not a


def test_a_render_from_kept_rays_is_byte_identical_to_one_that_computes_them():
    s = scene.make_scene(3)
    scene._RAYS.clear()
    first = scene.render(s, small_rig(), seed=3)
    assert len(scene._RAYS) == 2                              # both cameras' rays kept
    again = scene.render(s, small_rig(), seed=3)
    for a, b in ((first[0], again[0]), (first[1], again[1]), (first[2].depth_left_mm, again[2].depth_left_mm),
                 (first[2].cover_left, again[2].cover_left), (first[2].cover_right, again[2].cover_right),
                 (first[2].features.left_px, again[2].features.left_px)):
        assert a.tobytes() == b.tobytes()
    assert np.array_equal(first[2].features.visible_right, again[2].features.visible_right)
