"""Shared test helpers: paths of the repository and its fixtures."""

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "fixtures"


@pytest.fixture
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session", autouse=True)
def _compiled_kernels():
    """Compile the localizer's numba kernels into their disk cache once, before the first test: the first
    compile takes about a minute, and must not eat the deadline of a test that starts `appliance` as a
    process (those then load the kernels from the cache in a fraction of a second)."""
    from appliance.localize import kernels

    kernels.warm_up()


@pytest.fixture(scope="session")
def rendered_scene():
    """A function: seed -> (left, right, truth, calibration) of the accuracy benchmark's rendered scene of that
    seed (2x2 supersamples, as the benchmark's cache), each rendered once per session (~9 s each)."""
    from functools import lru_cache

    from appliance.synth.rig import default_rig
    from appliance.synth.scene import make_scene, render
    rig = default_rig()

    @lru_cache(maxsize=None)
    def scene(seed: int):
        left, right, truth = render(make_scene(seed), rig, seed=seed, ss=2)
        return left, right, truth, rig.calibration()
    return scene
