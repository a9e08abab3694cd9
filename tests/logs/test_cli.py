"""`appliance logs check` on intact, gapped and broken files (the real executable)."""

from __future__ import annotations

from appliance.logs import LogWriter, check_log

from .conftest import logging_cfg, make_frame, make_result
from .test_crash import cli


def test_check_an_intact_log_prints_the_table_and_exits_0(tmp_path, calib):
    with LogWriter(tmp_path / "ok.mcap", logging_cfg(), calibration=calib) as writer:
        for seq in range(6):
            writer.write_frame(make_frame(seq))
            writer.write_result(make_result(seq), seq)
    r = cli("logs", "check", str(writer.path))
    assert r.returncode == 0, r.stderr
    for topic in ("/camera/left/image", "/camera/right/calibration", "/localize/result", "/localize/branches"):
        assert topic in r.stdout
    assert "foxglove.CompressedImage" in r.stdout and "6 stereo pairs" in r.stdout
    assert "no gaps" in r.stdout and "intact" in r.stdout and "NOT" not in r.stdout


def test_check_reports_gaps_in_the_frames(tmp_path, calib):
    kept = [0, 1, 2, 5, 6, 7, 8, 20, 21, 0, 1]  # 2 pairs missing after 2, 11 after 8; seq restarts after 21
    with LogWriter(tmp_path / "gaps.mcap", logging_cfg(), calibration=calib) as writer:
        for seq in kept:
            writer.write_frame(make_frame(seq))
    summary = check_log(writer.path)
    assert [(g.after_seq, g.before_seq, g.missing) for g in summary.gaps] == [(2, 5, 2), (8, 20, 11), (21, 0, 0)]
    assert summary.frames == len(kept)
    r = cli("logs", "check", str(writer.path))
    assert r.returncode == 0
    assert "3 gap(s)" in r.stdout and "11 pair(s) missing" in r.stdout


def test_check_errors_name_the_file(tmp_path):
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"this is not an mcap file at all")
    r = cli("logs", "check", str(junk))
    assert r.returncode == 1 and r.stderr.strip() == f"error: {junk}: not an MCAP file (or an empty one)"
    r = cli("logs", "check", str(tmp_path / "missing.mcap"))
    assert r.returncode == 1 and "missing.mcap: no such log file" in r.stderr
    r = cli("logs", "check", str(tmp_path))
    assert r.returncode == 1 and "is a folder" in r.stderr


def test_check_several_files_fails_when_one_is_not_intact(tmp_path, calib):
    with LogWriter(tmp_path / "whole.mcap", logging_cfg(), calibration=calib) as writer:
        for seq in range(3):
            writer.write_frame(make_frame(seq))
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(writer.path.read_bytes()[:-100])
    assert cli("logs", "check", str(writer.path)).returncode == 0
    r = cli("logs", "check", str(writer.path), str(cut))
    assert r.returncode == 1
    assert r.stdout.count("3 stereo pairs") == 2 and r.stdout.count("NOT intact") == 1
    assert "cut.mcap: not intact" in r.stderr and "whole.mcap" not in r.stderr
