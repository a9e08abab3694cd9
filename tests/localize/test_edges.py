"""Row runs of masks (localize/edges.py) against a plain per-row scan."""

from __future__ import annotations

import numpy as np
import pytest
from appliance.localize.edges import find_runs

from tests.localize.shapes import y_shape


def scan_runs(binary: np.ndarray) -> list[tuple[int, int, int]]:
    """(row, first, last) of every run of True, row by row (the obvious loop)."""
    out = []
    for r, line in enumerate(binary):
        c = 0
        while c < len(line):
            if line[c]:
                s = c
                while c + 1 < len(line) and line[c + 1]:
                    c += 1
                out.append((r, s, c))
            c += 1
    return out


def as_list(runs) -> list[tuple[int, int, int]]:
    return list(zip(runs.row.tolist(), runs.x0.tolist(), runs.x1.tolist()))


@pytest.mark.parametrize("seed", range(6))
def test_runs_match_a_row_scan_on_random_masks(seed):
    rng = np.random.default_rng(seed)
    h, w = rng.integers(1, 50, 2)
    soft = rng.integers(0, 256, (h, w)).astype(np.uint8) * (rng.random((h, w)) < rng.random())
    for m in (soft, np.ascontiguousarray(soft.T), soft.T, soft[::2, 1:]):     # copies and views
        runs = find_runs(m, soft=True)
        assert as_list(runs) == scan_runs(m >= 128)
        assert runs.row.dtype == runs.x0.dtype == np.int64
        assert (runs.left_px <= runs.x0).all() and (runs.right_px >= runs.x1).all()
        hard = find_runs(m)
        assert as_list(hard) == scan_runs(m > 0)
        np.testing.assert_array_equal(hard.left_px, hard.x0 - 0.5)
    assert as_list(find_runs(soft.astype(np.float32) / 300)) == scan_runs(soft > 0)   # non-uint8 masks too


def test_runs_touching_the_borders_and_empty_masks():
    m = np.zeros((3, 5), np.uint8)
    m[0, :] = 255                       # a whole row
    m[1, 0] = m[1, 4] = 255             # single pixels at both borders
    runs = find_runs(m, soft=True)
    assert as_list(runs) == [(0, 0, 4), (1, 0, 0), (1, 4, 4)]
    np.testing.assert_array_equal(runs.left_px, [-0.5, -0.5, 3.5])
    np.testing.assert_array_equal(runs.right_px, [4.5, 0.5, 4.5])
    empty = find_runs(np.zeros((4, 6), np.uint8), soft=True)
    assert len(empty.row) == 0 and empty.left_px.dtype == float


def test_soft_boundaries_lie_where_the_coverage_crosses_one_half():
    m = np.zeros((1, 8), np.uint8)
    m[0, 2:6] = 255
    m[0, 1], m[0, 6] = 64, 191          # a quarter and three quarters covered beyond the run
    runs = find_runs(m, soft=True)
    assert as_list(runs) == [(0, 2, 6)]
    # left: crossing between pixel 1 (64) and 2 (255); right: between 7 (0) and 6 (191)
    assert runs.left_px[0] == pytest.approx(1 + (127.5 - 64) / (255 - 64))
    assert runs.right_px[0] == pytest.approx(7 - (127.5 - 0) / 191)


def test_y_shape_runs_and_lookups():
    m = y_shape()
    runs = find_runs(m, soft=True)
    assert as_list(runs) == scan_runs(m >= 128)
    i = runs.find(np.array([150, 150, 5]), np.array([100.0, 20.0, 100.0]))
    assert i[0] >= 0 and runs.x0[i[0]] <= 100 <= runs.x1[i[0]] and i[1] == -1 and i[2] == -1
    q, r = runs.between(np.array([30, 150]), np.array([0.0, 0.0]), np.array([199.0, 199.0]))
    assert q.tolist() == [0, 0, 1]                     # two arms on row 30, the stem on row 150
    assert (runs.row[r] == np.array([30, 30, 150])).all()
