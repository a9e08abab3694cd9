"""A writer killed with SIGKILL: `logs check` says not intact, `logs recover` keeps all but ~1 s."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

from mcap.reader import make_reader

from appliance.logs import check_log

from .conftest import PYTHON

HERE = Path(__file__).parent
APPLIANCE = str(Path(PYTHON).with_name("appliance"))
RATE_HZ = 30


def cli(*args):
    return subprocess.run([APPLIANCE, *args], capture_output=True, text=True, timeout=120)


def kill_writer_after(path: Path, seconds: float, *overrides: str) -> list[tuple[int, int]]:
    """Start endless_writer.py, SIGKILL it ``seconds`` after its first pair; (seq, stamp) it reported."""
    proc = subprocess.Popen([PYTHON, str(HERE / "endless_writer.py"), str(path), *overrides],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = proc.stdout.readline()
        assert first, proc.stderr.read()
        time.sleep(seconds)
        os.kill(proc.pid, signal.SIGKILL)
        rest = proc.stdout.read()
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    return [tuple(map(int, line.split()[:2])) for line in (first + rest).splitlines()]


def test_killed_log_is_recovered_but_for_the_last_second(tmp_path):
    log = tmp_path / "killed.mcap"
    # Chunks far larger than 2 s of data: only logging.flush_interval_s (1 s) bounds the loss.
    reported = kill_writer_after(log, 2.0, "chunk_size_bytes=67108864", "flush_interval_s=1.0")
    assert len(reported) >= 40  # ~2 s at 30 Hz

    r = cli("logs", "check", str(log))
    assert r.returncode != 0
    assert "NOT intact" in r.stdout and "truncated" in r.stdout
    assert "/camera/left/image" in r.stdout

    out = tmp_path / "recovered.mcap"
    r = cli("logs", "recover", str(log), "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "intact" in r.stdout and out.is_file()

    with open(out, "rb") as fh:  # the seeking reader goes by the new index
        reader = make_reader(fh)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes
        left = [m for _, ch, m in reader.iter_messages(topics=["/camera/left/image"])]
    seqs = [m.sequence for m in left]
    assert seqs == list(range(len(seqs)))
    last_seq, last_stamp = reported[-1]
    lost = last_seq + 1 - len(seqs)
    assert lost <= RATE_HZ * 1.0 + 3, f"lost {lost} of {last_seq + 1} pairs"
    assert (last_stamp - left[-1].log_time) / 1e9 <= 1.2

    recovered = check_log(out)
    assert recovered.intact and recovered.frames == len(seqs)
    assert recovered.counts["/localize/result"] >= len(seqs) - 1
    assert sorted(recovered.metadata) == ["calibration", "config", "device", "version"]


def test_recover_names_its_output_and_keeps_an_existing_one(tmp_path):
    log = tmp_path / "cut.mcap"
    kill_writer_after(log, 1.3)
    r = cli("logs", "recover", str(log))
    assert r.returncode == 0, r.stderr
    default_out = tmp_path / "cut.recovered.mcap"
    assert check_log(default_out).intact

    r = cli("logs", "recover", str(log))
    assert r.returncode == 1 and "exists" in r.stderr and "--force" in r.stderr
    assert cli("logs", "recover", str(log), "--force").returncode == 0


def test_flush_hands_a_quiet_log_to_the_os(tmp_path, calib):
    """After flush() the pairs so far are readable from the unfinished file (as after a kill)."""
    from appliance.logs import LogWriter, iter_stereo_frames

    from .conftest import logging_cfg, make_frame

    writer = LogWriter(tmp_path / "quiet.mcap", logging_cfg(flush_interval_s=3600), calibration=calib)
    for seq in range(3):
        writer.write_frame(make_frame(seq))
    assert [f.seq for f in iter_stereo_frames(writer.path)] == []
    assert writer.flush()
    assert [f.seq for f in iter_stereo_frames(writer.path)] == [0, 1, 2]
    assert not check_log(writer.path).intact
    writer.close()
    assert check_log(writer.path).intact
