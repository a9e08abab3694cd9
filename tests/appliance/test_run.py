"""`appliance run` and `appliance replay` as real processes on the bundled fixtures."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from appliance.logs import check_log, iter_stereo_frames, read_diagnostics, read_log_metadata, read_results

APPLIANCE = str(Path(sys.executable).with_name("appliance"))
FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"
SCENES = FIXTURES / "scenes"
RIG = FIXTURES / "rig.yaml"
N_SCENES = len(list(SCENES.glob("left_*.png")))


def appliance(*args, timeout=300):
    return subprocess.run([APPLIANCE, *args], capture_output=True, text=True, timeout=timeout)


def write_config(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def only_log(folder: Path) -> Path:
    logs = sorted(folder.glob("*.mcap"))
    assert len(logs) == 1, logs
    return logs[0]


def start_looping_run(tmp_path: Path, *extra: str) -> subprocess.Popen:
    cfg = write_config(tmp_path / "loop.yaml", "camera:\n  fake_loop: true\n"
                                               "logging:\n  flush_interval_s: 0.5\n")
    return subprocess.Popen([APPLIANCE, "run", "--device", f"fake:{SCENES}", "--calib", str(RIG),
                             "--log", str(tmp_path / "logs"), "--config", str(cfg), "-q", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_pairs(folder: Path, proc: subprocess.Popen, seconds: float) -> None:
    """Let the run go on for ``seconds`` after its log file appeared."""
    deadline = time.monotonic() + 120
    while not list(folder.glob("*.mcap")):
        assert proc.poll() is None, proc.communicate()[1]
        assert time.monotonic() < deadline, "no log file appeared"
        time.sleep(0.1)
    time.sleep(seconds)


@pytest.fixture(scope="module")
def fixture_run(tmp_path_factory):
    """(finished process, log) of one `appliance run` on the fixtures with the defaults, for the tests that read
    such a log (each ~4 s of CPU)."""
    folder = tmp_path_factory.mktemp("fixture_run")
    r = appliance("run", "--device", f"fake:{SCENES}", "--calib", str(RIG), "--log", str(folder), "-q")
    assert r.returncode == 0, r.stderr
    return r, only_log(folder)


def test_run_logs_every_topic_for_every_pair(fixture_run):
    r, log = fixture_run
    assert f"pairs {N_SCENES}, localized {N_SCENES}" in r.stdout
    counts: dict[str, int] = {}
    with open(log, "rb") as f:
        reader = make_reader(f)
        for _schema, channel, _message in reader.iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
        metadata = {m.name for m in reader.iter_metadata()}
    for topic in ("/camera/left/image", "/camera/right/image", "/localize/result", "/localize/branches",
                  "/tf"):
        assert counts[topic] == N_SCENES, (topic, counts)
    assert counts["/camera/left/calibration"] == counts["/camera/right/calibration"] == 1
    assert counts["/diagnostics"] >= 1
    assert read_diagnostics(log)[-1]["localized"] == N_SCENES     # the final counters
    assert {"config", "calibration", "version", "device"} <= metadata
    results = read_results(log)
    assert [seq for seq, _, _ in results] == list(range(N_SCENES))
    assert all(r.features and r.branches for _, _, r in results)
    device = read_log_metadata(log)["device_info"]
    assert device["device"] == f"fake:{SCENES}" and device["variant"] == "improved"
    assert (int(device["width_px"]), int(device["height_px"])) == (1280, 960)
    assert check_log(log).intact


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_finishes_an_indexed_log(tmp_path, sig):
    proc = start_looping_run(tmp_path)
    wait_for_pairs(tmp_path / "logs", proc, 3.0)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    log = only_log(tmp_path / "logs")
    summary = check_log(log)
    assert summary.intact, summary
    pairs = int(out.split("pairs ")[1].split(",")[0])
    assert pairs > N_SCENES                      # it looped: more pairs than the folder holds
    frames = list(iter_stereo_frames(log))
    assert len(frames) == pairs                  # a replay source is never dropped: every pair logged
    assert len(read_results(log)) == pairs
    diagnostics = read_diagnostics(log)
    assert diagnostics and diagnostics[-1]["localized"] <= pairs


def test_a_camera_faster_than_the_loop_drops_pairs_and_counts_them(tmp_path):
    # fake: at a fixed rate stands in for a camera: never stalled; what the writer (lossless PNG,
    # a queue of one pair) cannot take is counted, never waited for.
    cfg = write_config(tmp_path / "fast.yaml", "camera:\n  fake_loop: true\n  fake_rate_hz: 200.0\n"
                                               "logging:\n  image_encoding: png\n  queue_frames: 1\n")
    r = appliance("run", "--device", f"fake:{SCENES}", "--calib", str(RIG), "--log", str(tmp_path / "logs"),
                  "--frames", "60", "--config", str(cfg), "-q")
    assert r.returncode == 0, r.stderr
    log = only_log(tmp_path / "logs")
    final = read_diagnostics(log)[-1]
    assert final["pairs"] == 60
    assert final["dropped_localize"] > 0 and final["localized"] + final["dropped_localize"] == 60
    assert len(read_results(log)) == final["localized"] - final["dropped_log"]
    assert len(list(iter_stereo_frames(log))) == final["localized"] - final["dropped_log"]


def test_sigkill_leaves_a_log_that_recovers_all_but_the_last_second(tmp_path):
    proc = start_looping_run(tmp_path)
    wait_for_pairs(tmp_path / "logs", proc, 4.0)
    killed_ns = time.time_ns()
    os.kill(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=30)
    log = only_log(tmp_path / "logs")
    assert not check_log(log).intact
    fixed = tmp_path / "fixed.mcap"
    r = appliance("logs", "recover", str(log), "--out", str(fixed))
    assert r.returncode == 0, r.stderr
    assert check_log(fixed).intact
    with open(fixed, "rb") as f:
        published = [m.publish_time for _s, c, m in make_reader(f).iter_messages(topics=["/camera/left/image"])]
    assert len(published) >= 2
    assert killed_ns - max(published) < 1.5e9    # at most about the last second is lost


def test_replay_reproduces_a_lossless_log_exactly(tmp_path):
    cfg = write_config(tmp_path / "png.yaml", "logging:\n  image_encoding: png\n")
    r = appliance("run", "--device", f"fake:{SCENES}", "--calib", str(RIG), "--log", str(tmp_path / "logs"),
                  "--config", str(cfg), "-q")
    assert r.returncode == 0, r.stderr
    log = only_log(tmp_path / "logs")
    out = tmp_path / "replay.json"
    r = appliance("replay", str(log), "--json", str(out), "--log", str(tmp_path / "again"))
    assert r.returncode == 0, r.stderr
    report = json.loads(out.read_text())
    assert report["frames"] == N_SCENES
    assert report["identical"] == N_SCENES, report["diffs"]
    assert f"{N_SCENES} identical" in r.stdout
    assert len(read_results(only_log(tmp_path / "again"))) == N_SCENES


def test_a_log_replays_through_the_run_loop(tmp_path, fixture_run):
    first = fixture_run[1]
    r = appliance("run", "--device", f"fake:{first}", "--calib", str(RIG), "--log", str(tmp_path / "again"), "-q")
    assert r.returncode == 0, r.stderr
    assert f"pairs {N_SCENES}, localized {N_SCENES}" in r.stdout
    again = only_log(tmp_path / "again")
    stamps = [f.stamp_ns for f in iter_stereo_frames(first)]
    assert [f.stamp_ns for f in iter_stereo_frames(again)] == stamps      # the recorded stamps, in order
    assert len(read_results(again)) == N_SCENES


def test_replay_with_other_settings_reports_the_differences(tmp_path, fixture_run):
    log = fixture_run[1]
    (tmp_path / "a_file").write_text("")      # an output under a file: refused before any frame is replayed
    r = appliance("replay", str(log), "--json", str(tmp_path / "a_file" / "replay.json"))
    assert r.returncode == 1 and "frames replayed" not in r.stdout
    assert r.stderr.strip().startswith("error: ") and "replay.json: cannot make its folder" in r.stderr
    out = tmp_path / "replay.json"
    r = appliance("replay", str(log), "--variant", "paper", "--json", str(out))
    assert r.returncode == 0, r.stderr
    diffs = json.loads(out.read_text())["diffs"]
    assert len(diffs) == N_SCENES
    assert any(not d["identical"] and (d["added"] or d["removed"] or d["max_abs_dz_mm"] > 0) for d in diffs)


def test_localizer_processes_give_the_same_results_in_order(tmp_path, fixture_run):
    r = appliance("run", "--device", f"fake:{SCENES}", "--calib", str(RIG), "--log", str(tmp_path), "--workers", "2",
                  "-q")
    assert r.returncode == 0, r.stderr
    assert "resource_tracker" not in r.stderr and "leaked" not in r.stderr    # shared frames freed once
    one, two = ([(seq, json.dumps({**res.to_dict(), "timings_ms": {}, "stamp_ns": 0}, sort_keys=True))
                 for seq, _, res in read_results(log)] for log in (fixture_run[1], only_log(tmp_path)))
    assert [seq for seq, _ in two] == list(range(N_SCENES))
    assert one == two


def test_a_lost_camera_is_reopened_and_the_run_goes_on(tmp_path):
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    for name in ("left_00.png", "right_00.png", "left_01.png", "right_01.png"):
        shutil.copy(SCENES / name, scenes / name)
    (scenes / "left_02.png").write_bytes(b"not a png")      # unreadable mid-stream: the camera is lost
    shutil.copy(SCENES / "right_02.png", scenes / "right_02.png")
    cfg = write_config(tmp_path / "c.yaml", "camera:\n  fake_loop: true\n  fake_rate_hz: -1\n"
                                            "  reconnect_min_s: 0.05\n  reconnect_max_s: 0.1\n")
    r = appliance("run", "--device", f"fake:{scenes}", "--calib", str(RIG), "--no-log", "--frames", "5",
                  "--config", str(cfg), "-q")
    assert r.returncode == 0, r.stderr
    assert "pairs 5, localized 5" in r.stdout
    reconnects = int(r.stdout.split("reconnects ")[1].split()[0])
    assert reconnects >= 2


def _scenes_with_small_pairs(tmp_path: Path, pairs: int, small: range) -> Path:
    """A folder of ``pairs`` fixture pairs (cycled) whose pairs ``small`` are half size: the localizer
    refuses them."""
    import cv2

    scenes = tmp_path / "scenes"
    scenes.mkdir()
    for i in range(pairs):
        for side in ("left", "right"):
            source = SCENES / f"{side}_{i % N_SCENES:02d}.png"
            if i in small:
                cv2.imwrite(str(scenes / f"{side}_{i:02d}.png"), cv2.resize(cv2.imread(str(source)), (640, 480)))
            else:
                shutil.copy(source, scenes / f"{side}_{i:02d}.png")
    return scenes


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_pair_the_localizer_fails_on_is_counted_logged_and_skipped(tmp_path, workers):
    scenes = _scenes_with_small_pairs(tmp_path, N_SCENES, small=range(1, 2))
    r = appliance("run", "--device", f"fake:{scenes}", "--calib", str(RIG), "--log", str(tmp_path / "logs"),
                  "--workers", workers, "-q")
    assert r.returncode == 0, r.stderr
    assert f"pairs {N_SCENES}, localized {N_SCENES - 1}, failed 1," in r.stdout
    log = only_log(tmp_path / "logs")
    assert check_log(log).intact
    assert [seq for seq, _, _ in read_results(log)] == [i for i in range(N_SCENES) if i != 1]
    assert [f.seq for f in iter_stereo_frames(log)] == list(range(N_SCENES))   # its frames kept, for replay
    diagnostics = read_diagnostics(log)
    notes = [d["message"] for d in diagnostics if "message" in d]
    assert any(n.startswith("localize failed on pair 1 (stamp_ns ") and "640x480" in n for n in notes), notes
    assert diagnostics[-1]["failed_localize"] == 1


def test_a_localizer_failing_on_every_pair_stops_the_run_in_one_line(tmp_path):
    from appliance.run import MAX_FAILED_IN_ROW as limit

    scenes = _scenes_with_small_pairs(tmp_path, limit + 3, small=range(1, limit + 3))
    cfg = write_config(tmp_path / "fast.yaml", "camera:\n  fake_rate_hz: -1\n")
    r = appliance("run", "--device", f"fake:{scenes}", "--calib", str(RIG), "--log", str(tmp_path / "logs"),
                  "--config", str(cfg), "-q")
    assert r.returncode == 1
    assert r.stderr.startswith("error: ") and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert f"failed on {limit} pairs in a row" in r.stderr and str(scenes) in r.stderr
    log = only_log(tmp_path / "logs")
    assert check_log(log).intact
    assert read_diagnostics(log)[-1]["failed_localize"] >= limit


def test_a_full_disk_stops_logging_but_not_localizing(tmp_path):
    cfg = write_config(tmp_path / "c.yaml", "logging:\n  min_free_bytes: 1000000000000000\n")
    r = appliance("run", "--device", f"fake:{SCENES}", "--calib", str(RIG), "--log", str(tmp_path / "logs"),
                  "--config", str(cfg), "-q")
    assert r.returncode == 0, r.stderr
    assert f"pairs {N_SCENES}, localized {N_SCENES}" in r.stdout
    assert "logging stopped" in r.stderr


@pytest.mark.parametrize("args, message", [
    (["--device", "fake:/nonexistent/folder"], "fake:/nonexistent/folder"),
    (["--device", "/dev/video9"], "/dev/video9: no such device"),
    (["--calib", "/nonexistent/calib.yaml"], "/nonexistent/calib.yaml"),
])
def test_bad_input_is_one_line_naming_it(args, message):
    base = {"--device": f"fake:{SCENES}", "--calib": str(RIG)}
    base.update(dict(zip(args[::2], args[1::2])))
    r = appliance("run", *[x for kv in base.items() for x in kv], "--no-log", "-q")
    assert r.returncode == 1
    assert r.stderr.startswith("error: ") and message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_a_missing_serial_port_is_one_line_and_leaves_a_readable_log(tmp_path):
    r = appliance("run", "--device", f"fake:{SCENES}", "--calib", str(RIG), "--log", str(tmp_path),
                  "--serial", "/dev/nonexistent-tty", "-q")
    assert r.returncode == 1
    assert r.stderr.startswith("error: ") and "/dev/nonexistent-tty" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert check_log(only_log(tmp_path)).intact


def test_calibration_of_another_image_size_is_refused(tmp_path):
    small = tmp_path / "small"
    small.mkdir()
    import cv2

    for side in ("left", "right"):
        img = cv2.imread(str(SCENES / f"{side}_00.png"))
        cv2.imwrite(str(small / f"{side}_00.png"), cv2.resize(img, (640, 480)))
    r = appliance("run", "--device", f"fake:{small}", "--calib", str(RIG), "--no-log", "-q")
    assert r.returncode == 1
    assert "640x480" in r.stderr and "1280x960" in r.stderr
