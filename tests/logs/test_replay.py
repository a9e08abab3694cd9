"""A log replays through the fake driver (``fake:LOG.mcap``): the logged pairs, in order, with their stamps."""

from __future__ import annotations

import time

import numpy as np

from appliance.acquire import open_driver
from appliance.config import load_config
from appliance.logs import LogWriter, recover_log

from .conftest import PERIOD_NS, logging_cfg, make_frame
from .test_crash import kill_writer_after

N = 10


def camera_cfg(**camera):
    return load_config(overrides={"camera": camera}).camera


def lossless_log(path, calib):
    with LogWriter(path, logging_cfg(image_encoding="png"), calibration=calib) as writer:
        for seq in range(N):
            writer.write_frame(make_frame(seq))
    return writer.path


def test_fake_driver_replays_the_logged_pairs(tmp_path, calib):
    log = lossless_log(tmp_path / "run.mcap", calib)
    with open_driver(f"fake:{log}", camera_cfg(fake_rate_hz=-1)) as driver:
        frames = list(driver)
        assert (driver.info.width_px, driver.info.height_px) == (calib.image_size[0], calib.image_size[1])
    assert [f.seq for f in frames] == list(range(N))
    for f in frames:
        logged = make_frame(f.seq)
        assert (f.stamp_left_ns, f.stamp_right_ns) == (logged.stamp_left_ns, logged.stamp_right_ns)
        assert np.array_equal(f.left, logged.left) and np.array_equal(f.right, logged.right)


def test_fake_driver_replays_at_the_recorded_pace(tmp_path, calib):
    log = lossless_log(tmp_path / "run.mcap", calib)
    start = time.monotonic()
    with open_driver(f"fake:{log}", camera_cfg(fake_rate_hz=0)) as driver:
        frames = list(driver)
    elapsed = time.monotonic() - start
    assert len(frames) == N
    assert elapsed >= (N - 1) * PERIOD_NS / 1e9 * 0.95


def test_a_killed_log_replays_as_far_as_it_is_whole(tmp_path):
    log = tmp_path / "killed.mcap"
    kill_writer_after(log, 1.5, "flush_interval_s=0.5")
    with open_driver(f"fake:{log}", camera_cfg(fake_rate_hz=-1)) as driver:
        seqs = [f.seq for f in driver]
    recovered = recover_log(log, tmp_path / "recovered.mcap")
    assert len(seqs) == recovered.frames >= 20
    assert seqs == list(range(len(seqs)))
