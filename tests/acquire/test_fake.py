"""The fake driver replays folders and side-by-side videos in order, with stamps and at the rate asked."""

from __future__ import annotations

import itertools
import time

import numpy as np
import pytest

from appliance.acquire import DeviceNotFound, FormatNotSupported, open_driver

from .conftest import H, W, camera_cfg, pair_number


def take(driver, n):
    return list(itertools.islice(driver, n))


def test_folder_in_order_with_synthetic_stamps(pair_folder):
    before = time.time_ns()
    with open_driver(f"fake:{pair_folder}", camera_cfg(fake_rate_hz=-1)) as driver:
        frames = list(driver)
    assert (driver.info.driver, driver.info.width_px, driver.info.height_px) == ("fake", W, H)
    assert driver.info.fps_hz == 10.0 and driver.dropped_pairs == 0
    assert [f.seq for f in frames] == list(range(6))
    assert [pair_number(f.left) for f in frames] == list(range(6))
    assert all(np.array_equal(f.right[H // 2:], np.full((H // 2, W, 3), 220 - 20 * i, np.uint8))
               for i, f in enumerate(frames))
    stamps = np.array([f.stamp_ns for f in frames])
    assert before <= stamps[0] <= time.time_ns()
    assert np.all(np.diff(stamps) == 100_000_000)  # 10 Hz, the folder's nominal rate
    assert all(f.stamp_left_ns == f.stamp_right_ns for f in frames)


def test_fixed_rate_is_kept(pair_folder):
    cfg = camera_cfg(fake_rate_hz=50.0, fake_loop=True)
    with open_driver(f"fake:{pair_folder}", cfg) as driver:
        frames = iter(driver)
        next(frames)
        start = time.monotonic()
        got = take(frames, 10)
        elapsed_s = time.monotonic() - start
    rate_hz = 10 / elapsed_s
    assert 40.0 < rate_hz < 55.0, rate_hz
    assert np.all(np.diff([f.stamp_ns for f in got]) == 20_000_000)


def test_loop_restarts_and_stamps_keep_increasing(pair_folder):
    with open_driver(f"fake:{pair_folder}", camera_cfg(fake_rate_hz=-1, fake_loop=True)) as driver:
        frames = take(driver, 14)
    assert [pair_number(f.left) for f in frames] == [0, 1, 2, 3, 4, 5] * 2 + [0, 1]
    assert [f.seq for f in frames] == list(range(14))
    assert np.all(np.diff([f.stamp_ns for f in frames]) > 0)


def test_a_looping_folder_is_decoded_once_and_delivered_read_only(pair_folder):
    with open_driver(f"fake:{pair_folder}", camera_cfg(fake_rate_hz=-1, fake_loop=True)) as driver:
        frames = take(driver, 8)
    assert frames[6].left is frames[0].left and frames[7].right is frames[1].right   # the first lap's arrays
    assert not frames[0].left.flags.writeable
    with pytest.raises(ValueError):
        frames[0].left[0, 0] = 0


def test_side_by_side_video_at_its_own_rate(sbs_video):
    with open_driver(f"fake:{sbs_video}", camera_cfg(fake_rate_hz=-1)) as driver:
        frames = list(driver)
    assert driver.info.fps_hz == 25.0 and (driver.info.width_px, driver.info.height_px) == (W, H)
    assert [pair_number(f.left) for f in frames] == list(range(6))
    assert [round(220 - f.right[H // 2:].mean()) // 20 for f in frames] == list(range(6))
    assert np.all(np.diff([f.stamp_ns for f in frames]) == 40_000_000)


def test_replay_errors_name_the_path(tmp_path):
    cfg = camera_cfg()
    with pytest.raises(DeviceNotFound, match=r"^fake:.*nowhere: no such folder or file$"):
        open_driver(f"fake:{tmp_path / 'nowhere'}", cfg)
    (tmp_path / "empty").mkdir()
    with pytest.raises(DeviceNotFound, match=r"empty: no left/right image pairs in this folder"):
        open_driver(f"fake:{tmp_path / 'empty'}", cfg)
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(FormatNotSupported, match=r"notes.txt: not a folder, an .mcap log or a video"):
        open_driver(f"fake:{tmp_path / 'notes.txt'}", cfg)
