"""Shared test helpers: paths of the repository and its fixtures."""

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "fixtures"


@pytest.fixture
def repo() -> Path:
    return REPO


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
