"""The ray intersections against brute force: a round cone is the union of spheres interpolated between its ends."""

import numpy as np

from appliance.synth import raycast


def _inside_round_cone(p, a, b, ra, rb):
    """Signed distance-like test by dense sampling of the sphere family, (N,) mm (< 0 inside)."""
    s = np.linspace(0, 1, 1001)
    c = a[None, :] + s[:, None] * (b - a)[None, :]
    r = ra + s * (rb - ra)
    return (np.linalg.norm(p[:, None, :] - c[None], axis=2) - r[None]).min(axis=1)


def test_round_cone_first_hit_matches_brute_force():
    rng = np.random.default_rng(3)
    hits = misses = 0
    for _ in range(30):
        a = rng.uniform(-50, 50, 3) + [0, 0, 1000]
        b = a + rng.normal(0, 40, 3)
        ra, rb = rng.uniform(8, 25), rng.uniform(4, 8)
        target = a + rng.uniform(-0.2, 1.2) * (b - a) + rng.normal(0, 15, 3)
        d = target / np.linalg.norm(target)
        o = np.zeros(3)
        t = raycast.round_cone(o, d[None], a, b, ra, rb)[0]
        ts = np.linspace(700, 1300, 1500)
        sd = _inside_round_cone(ts[:, None] * d[None], a, b, ra, rb)
        if np.isfinite(t):
            hits += 1
            assert abs(_inside_round_cone((t * d)[None], a, b, ra, rb)[0]) < 0.02
            assert (sd[ts < t - 0.5] > 0).all()          # nothing nearer
        else:
            misses += 1
            assert (sd > -0.05).all()
    assert hits > 10 and misses > 3


def test_sphere_disc_and_plane():
    o = np.zeros(3)
    d = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    t = raycast.sphere(o, d, [0, 0, 1000], 40)
    assert np.isclose(t[0], 960) and np.isinf(t[1])
    t, u, _ = raycast.ellipse_disc(o, d, [0, 0, 800], [0, 0, -1], [1, 0, 0], [0, 1, 0], 30, 10)
    assert np.isclose(t[0], 800) and abs(u[0]) < 1e-12 and np.isinf(t[1])
    assert np.allclose(raycast.plane_z(o, d[:, 2], 4000), [4000, 5000])
