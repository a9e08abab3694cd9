"""benchmarks/localize_accuracy.py --ss: the scene cache per supersampling and the renderer it drives."""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


def _module(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(name, mod)
    spec.loader.exec_module(mod)
    return sys.modules[name]


bench = _module("localize_accuracy", REPO / "benchmarks" / "localize_accuracy.py")


def test_cache_per_ss_keeps_the_default_cache():
    assert bench.scene_cache(2) == REPO / "out" / "localize_scenes"
    assert bench.scene_cache(4) == REPO / "out" / "localize_scenes_ss4"
    assert bench.scene_cache(8) != bench.scene_cache(4)


def test_ss_argument_rejects_nonsense():
    assert bench._supersamples("4") == 4
    for bad in ("0", "-2", "two", "2.5"):
        with pytest.raises(argparse.ArgumentTypeError):
            bench._supersamples(bad)


def test_fixture_scenes_at_default_ss_are_the_committed_ones():
    found = bench.scenes(0, ss=2)
    assert [n for n, *_ in found] == ["fixture 00", "fixture 01", "fixture 02", "fixture 03"]
    assert all(p.parent == REPO / "fixtures" / "scenes" for _, *paths in found for p in paths)


def test_cached_scene_renders_with_ss_once(tmp_path, capsys):
    """ss 1 (one ray per pixel, the cheapest render): the truth's coverage is whole pixels (ss 2 gives
    quarters); the second call reuses the files."""
    left, right, truth = bench.cached_scene(101, tmp_path, ss=1, tag="t")
    assert "rendering scene 101 (ss 1)" in capsys.readouterr().out
    assert left == tmp_path / "left_t.png" and right.exists() and truth == tmp_path / "truth_t.json"
    cover = np.load(tmp_path / "truth_t.npz")["cover_left"]     # uint8, 255 = whole pixel
    assert set(np.unique(cover)) == {0, 255}
    mtime = left.stat().st_mtime_ns
    assert bench.cached_scene(101, tmp_path, ss=1, tag="t") == (left, right, truth)
    assert "rendering" not in capsys.readouterr().out
    assert left.stat().st_mtime_ns == mtime
