"""A full or nearly full disk stops logging with one message; the caller goes on, drops are counted."""

from __future__ import annotations

import json
import logging
import shutil
import subprocess

import pytest

from appliance.logs import LogError, LogWriter, check_log, iter_stereo_frames, recover_log

from .conftest import PYTHON, logging_cfg, make_frame, make_result
from .test_crash import HERE


def stop_messages(caplog):
    return [r for r in caplog.records if r.name == "appliance.logs" and "logging stopped" in r.getMessage()]


def test_min_free_bytes_above_the_free_space_stops_logging_at_once(tmp_path, calib, caplog):
    free = shutil.disk_usage(tmp_path).free
    with caplog.at_level(logging.WARNING):
        writer = LogWriter(tmp_path / "logs", logging_cfg(min_free_bytes=free * 1000), calibration=calib)
        for seq in range(5):
            assert writer.write_frame(make_frame(seq)) is False
            assert writer.write_result(make_result(seq), seq) is False
        assert writer.write_diagnostics({"rate_hz": 30.0}) is False
        writer.close()
    assert writer.stopped and "logging.min_free_bytes" in writer.stop_reason
    assert str(tmp_path / "logs") in writer.stop_reason
    assert (writer.frames_dropped, writer.results_dropped, writer.diagnostics_dropped) == (5, 5, 1)
    assert writer.frames_written == 0 and writer.paths == []
    assert len(stop_messages(caplog)) == 1
    assert "localization goes on" in stop_messages(caplog)[0].getMessage()


def test_disk_full_at_open_stops_logging_without_raising(tmp_path, calib, caplog):
    target = tmp_path / "full.mcap"
    target.symlink_to("/dev/full")  # every write: ENOSPC
    with caplog.at_level(logging.WARNING):
        with LogWriter(target, logging_cfg(min_free_bytes=0), calibration=calib) as writer:
            assert writer.write_frame(make_frame(0)) is False
    assert writer.stopped and "No space left on device" in writer.stop_reason
    assert writer.frames_dropped == 1 and len(stop_messages(caplog)) == 1


def test_a_folder_that_cannot_be_made_is_an_error_at_open(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    with pytest.raises(LogError, match="a_file/logs: cannot create the log folder"):
        LogWriter(blocker / "logs", logging_cfg())


def run_on_small_tmpfs(tmp_path, size: str, *args: str) -> tuple[dict, list[str], str]:
    """Run endless_writer.py on a tmpfs of ``size`` in a private mount namespace; copy the logs out."""
    if shutil.which("unshare") is None or subprocess.run(["unshare", "-m", "true"]).returncode != 0:
        pytest.skip("needs unshare -m (root) to mount a small tmpfs")
    small, out = tmp_path / "small", tmp_path / "copied"  # the tmpfs is seen only inside the namespace
    small.mkdir()
    out.mkdir()
    script = (f"mount -t tmpfs -o size={size} tmpfs {small} && "
              f"{PYTHON} {HERE / 'endless_writer.py'} {small}/logs {' '.join(args)} && cp {small}/logs/*.mcap {out}")
    r = subprocess.run(["unshare", "-m", "sh", "-c", script], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[-1].startswith("done ")
    return json.loads(lines[-1][5:]), lines[:-1], r.stderr


def test_low_disk_mid_run_finishes_the_file_and_the_writer_goes_on(tmp_path):
    stats, lines, stderr = run_on_small_tmpfs(tmp_path, "4m", "frames=150", "rate_hz=0",
                                              "min_free_bytes=1500000", "flush_interval_s=0.01")
    assert len(lines) == 150  # every pair was handed over and the loop went on
    assert "logging.min_free_bytes" in stats["stopped"]
    assert stats["frames_written"] > 20 and stats["frames_dropped"] > 0
    assert stats["frames_written"] + stats["frames_dropped"] == 150
    assert stderr.count("logging stopped") == 1
    (log,) = (tmp_path / "copied").iterdir()
    summary = check_log(log)
    assert summary.intact and summary.frames == stats["frames_written"]


def test_enospc_mid_run_stops_logging_and_leaves_a_recoverable_file(tmp_path):
    stats, lines, stderr = run_on_small_tmpfs(tmp_path, "2m", "frames=100", "rate_hz=0", "min_free_bytes=0",
                                              "chunk_size_bytes=262144", "flush_interval_s=1")
    assert len(lines) == 100
    assert "No space left on device" in stats["stopped"]
    assert stats["frames_written"] > 10 and stats["frames_dropped"] > 0
    assert stderr.count("logging stopped") == 1
    (log,) = (tmp_path / "copied").iterdir()
    recovered = recover_log(log, tmp_path / "recovered.mcap")
    assert recovered.intact
    seqs = [f.seq for f in iter_stereo_frames(tmp_path / "recovered.mcap")]
    # the chunk being written when the disk filled is lost: ~262 kB, 5-6 pairs of ~50 kB
    assert seqs == list(range(len(seqs))) and len(seqs) >= stats["frames_written"] - 7
