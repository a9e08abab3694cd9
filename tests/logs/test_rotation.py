"""Files rotate by size and by duration; each file stands alone (metadata, calibration, index)."""

from __future__ import annotations

import re

from appliance.logs import LogWriter, check_log, iter_stereo_frames, read_log_metadata

from .conftest import logging_cfg, make_frame, make_result

NAME = re.compile(r"field_\d{8}-\d{6}_(\d{3})\.mcap")


def write(folder, cfg, calib, n):
    with LogWriter(folder, cfg, calibration=calib, device="fake:rot", prefix="field") as writer:
        for seq in range(n):
            assert writer.write_frame(make_frame(seq))
            assert writer.write_result(make_result(seq), seq)
    return writer


def check_files(writer, n):
    """Every file intact and self-contained; together they hold seq 0..n-1 in order."""
    seqs = []
    for path in writer.paths:
        summary = check_log(path)
        assert summary.intact, summary.problem
        assert sorted(summary.metadata) == ["calibration", "config", "device", "version"]
        assert summary.counts["/camera/left/calibration"] == summary.counts["/camera/right/calibration"] == 1
        assert read_log_metadata(path)["calibration"] is not None
        seqs += [f.seq for f in iter_stereo_frames(path)]
    assert seqs == list(range(n))


def test_rotation_by_size(tmp_path, calib):
    limit = 200_000  # a pair of these 320x240 JPEGs is ~50 kB
    writer = write(tmp_path / "logs", logging_cfg(rotate_size_bytes=limit, rotate_duration_s=0), calib, 30)
    assert len(writer.paths) >= 5
    assert [int(NAME.fullmatch(p.name).group(1)) for p in writer.paths] == list(range(len(writer.paths)))
    assert all(p.parent == tmp_path / "logs" for p in writer.paths)
    # a file is closed at the first pair past the limit: over by less than one pair and its result
    assert all(p.stat().st_size < limit + 120_000 for p in writer.paths)
    assert writer.frames_written == 30 and writer.frames_dropped == 0
    check_files(writer, 30)


def test_rotation_by_duration(tmp_path, calib):
    writer = write(tmp_path, logging_cfg(rotate_duration_s=0.5, rotate_size_bytes=0), calib, 40)
    # 30 Hz stamps: pairs 0-15 span 0.5 s minus 5 ns, pair 16 opens the second file, 32 the third
    assert len(writer.paths) == 3
    assert [check_log(p).frames for p in writer.paths] == [16, 16, 8]
    for path in writer.paths:
        left = check_log(path).topics["/camera/left/image"]
        assert (left.last_ns - left.first_ns) / 1e9 < 0.5
    check_files(writer, 40)


def test_an_mcap_path_names_the_first_file(tmp_path, calib):
    writer = write(tmp_path / "trial.mcap", logging_cfg(rotate_duration_s=0.5), calib, 20)
    assert [p.name for p in writer.paths] == ["trial.mcap", "trial_000.mcap"]
    check_files(writer, 20)
