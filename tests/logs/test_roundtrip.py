"""A log written by LogWriter reads back whole: frames, results, metadata, every topic decodable."""

from __future__ import annotations

import json
from collections import Counter

import numpy as np
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from appliance.config import config_to_dict, load_config
from appliance.logs import (
    LogWriter, check_log, iter_stereo_frames, read_diagnostics, read_log_metadata, read_results,
)
from appliance.logs.messages import quaternion_from_matrix

from .conftest import CAMERA_TO_BASE, H, W, logging_cfg, make_frame, make_result

N = 12


def write_log(path, cfg, calib, n=N, results=True):
    config = load_config()
    with LogWriter(path, cfg, calibration=calib, config_dict=config_to_dict(config), device="fake:test",
                   version="9.8.7") as writer:
        for seq in range(n):
            assert writer.write_frame(make_frame(seq))
            if results:
                assert writer.write_result(make_result(seq, n_branches=seq % 3), seq, CAMERA_TO_BASE)
        assert writer.write_diagnostics({"rate_hz": 29.5, "drops": np.int64(0)}, make_frame(n - 1).stamp_ns)
    return writer


def test_png_frames_are_lossless_and_in_order(tmp_path, calib):
    writer = write_log(tmp_path / "run.mcap", logging_cfg(image_encoding="png"), calib)
    assert writer.paths == [tmp_path / "run.mcap"] and not writer.stopped
    frames = list(iter_stereo_frames(writer.path))
    assert [f.seq for f in frames] == list(range(N))
    for f in frames:
        expected = make_frame(f.seq)
        assert np.array_equal(f.left, expected.left) and np.array_equal(f.right, expected.right)
        assert (f.stamp_left_ns, f.stamp_right_ns) == (expected.stamp_left_ns, expected.stamp_right_ns)


def test_jpeg_frames_follow_the_quality(tmp_path, calib):
    errors, sizes = {}, {}
    for quality in (50, 95):
        writer = write_log(tmp_path / f"q{quality}.mcap", logging_cfg(jpeg_quality=quality), calib, n=3,
                           results=False)
        frames = list(iter_stereo_frames(writer.path))
        assert [f.seq for f in frames] == [0, 1, 2] and frames[0].left.shape == (H, W, 3)
        errors[quality] = np.mean([np.abs(f.left.astype(int) - make_frame(f.seq).left).mean() for f in frames])
        sizes[quality] = writer.path.stat().st_size
    assert errors[95] < errors[50] < 10.0
    assert sizes[95] > sizes[50]


def test_results_and_metadata_round_trip(tmp_path, calib):
    writer = write_log(tmp_path / "run.mcap", logging_cfg(), calib)
    results = read_results(writer.path)
    assert [seq for seq, _, _ in results] == list(range(N))
    for seq, stamp_ns, result in results:
        expected = make_result(seq, n_branches=seq % 3)
        assert stamp_ns == expected.stamp_ns
        assert result.to_dict() == expected.to_dict()

    meta = read_log_metadata(writer.path)
    assert meta["config"] == json.loads(json.dumps(config_to_dict(load_config())))
    assert meta["version"]["appliance"] == "9.8.7" and meta["device"] == "fake:test"
    logged = meta["calibration"]
    assert logged.image_size == calib.image_size
    for name in ("K1", "D1", "K2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q"):
        assert np.array_equal(getattr(logged, name), getattr(calib, name)), name
    assert logged.rms_px == calib.rms_px and logged.meta == calib.meta

    diagnostics = read_diagnostics(writer.path)
    assert len(diagnostics) == 1 and diagnostics[0]["rate_hz"] == 29.5
    assert diagnostics[0]["log_writer"]["frames_written"] == N


def test_every_topic_has_its_count_and_decodes_with_the_embedded_schema(tmp_path, calib):
    writer = write_log(tmp_path / "run.mcap", logging_cfg(), calib)
    expected = {"/camera/left/image": N, "/camera/right/image": N, "/camera/left/calibration": 1,
                "/camera/right/calibration": 1, "/tf_static": 1, "/localize/result": N,
                "/localize/branches": N, "/tf": N, "/diagnostics": 1}
    summary = check_log(writer.path)
    assert summary.intact and summary.problem is None
    assert summary.counts == expected and summary.frames == N and summary.gaps == []
    assert sorted(summary.metadata) == ["calibration", "config", "device", "version"]
    assert abs(summary.duration_s - (N - 1) * 1 / 30) < 0.002

    counts, schemas = Counter(), {}
    with open(writer.path, "rb") as fh:
        reader = make_reader(fh)
        stats = reader.get_summary().statistics
        assert stats.message_count == sum(expected.values())
        decoders = {}
        for schema, channel, message in reader.iter_messages():
            if channel.message_encoding == "protobuf":  # classes built from the schema in the file
                decoder = decoders.setdefault(channel.id, DecoderFactory().decoder_for("protobuf", schema))
                decoded = decoder(message.data)
                assert type(decoded).DESCRIPTOR.full_name == schema.name
            else:
                assert (channel.message_encoding, schema.encoding) == ("json", "jsonschema")
                decoded = json.loads(message.data)
            counts[channel.topic] += 1
            schemas[channel.topic] = schema.name
            if channel.topic == "/camera/left/image":
                assert decoded.format == "jpeg" and decoded.frame_id == "camera"
                assert decoded.timestamp.ToNanoseconds() == make_frame(message.sequence).stamp_left_ns
            elif channel.topic == "/camera/right/calibration":
                assert (decoded.width, decoded.height, decoded.frame_id) == (W, H, "camera_right")
                assert np.allclose(np.reshape(decoded.P, (3, 4))[:, :3], calib.P2[:, :3])
                assert np.isclose(decoded.P[3], calib.P2[0, 3] / 1000.0)  # baseline in metres
                assert np.allclose(decoded.K, calib.K2.ravel()) and decoded.distortion_model == "plumb_bob"
            elif channel.topic == "/localize/branches":
                result = make_result(message.sequence, n_branches=message.sequence % 3)
                cylinders = decoded.entities[0].cylinders
                assert len(cylinders) == sum(len(b.polyline_mm) - 1 for b in result.branches)
                for c in cylinders:  # its axis (local Z turned by the pose) has the segment's length
                    assert c.size.x == c.size.y > 0 and c.size.z > 0
            elif channel.topic == "/tf":
                assert (decoded.parent_frame_id, decoded.child_frame_id) == ("arm_base", "camera")
                t = decoded.translation
                assert np.allclose([t.x, t.y, t.z], CAMERA_TO_BASE[:3, 3] / 1000.0)
                q = decoded.rotation
                assert np.allclose([q.x, q.y, q.z, q.w], quaternion_from_matrix(CAMERA_TO_BASE[:3, :3]))
            elif channel.topic == "/localize/result":
                assert decoded["seq"] == message.sequence
                assert set(decoded) <= set(json.loads(schema.data)["properties"])
    assert counts == Counter(expected)
    assert schemas["/camera/left/image"] == "foxglove.CompressedImage"
    assert schemas["/localize/branches"] == "foxglove.SceneUpdate"
    assert schemas["/localize/result"] == "appliance.LocalizationResult"


def test_cylinders_lie_on_the_branch_axis(tmp_path, calib):
    """Each cylinder's centre is its segment's midpoint and its Z axis points along the segment."""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

    from appliance.logs.messages import branches_message

    result = make_result(4, n_branches=3)
    update = SceneUpdate.FromString(branches_message(result, 0).SerializeToString())
    cylinders = list(update.entities[0].cylinders)
    segments = [(p[k], p[k + 1]) for b in result.branches for p in [b.polyline_mm / 1000.0]
                for k in range(len(p) - 1)]
    assert len(cylinders) == len(segments) == 1 + 2 + 3
    for c, (a, b) in zip(cylinders, segments):
        pos, q = c.pose.position, c.pose.orientation
        assert np.allclose([pos.x, pos.y, pos.z], (a + b) / 2)
        x, y, z, w = q.x, q.y, q.z, q.w
        axis = np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])  # R @ e_z
        assert np.allclose(axis * c.size.z, b - a, atol=1e-9)


def test_quaternions_rebuild_their_rotations():
    import cv2

    rng = np.random.default_rng(3)
    rotations = [cv2.Rodrigues(rng.normal(size=3) * s)[0] for s in (0.01, 1.0, 3.0) for _ in range(20)]
    rotations += [np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])]
    for rot in rotations:
        x, y, z, w = quaternion_from_matrix(rot)
        assert w >= 0 and np.isclose(x * x + y * y + z * z + w * w, 1.0)
        rebuilt = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        assert np.allclose(rebuilt, rot, atol=1e-12)


def test_threads_may_write_at_once(tmp_path, calib):
    """Frames from one thread, results and diagnostics from another: all logged, the file whole."""
    import threading

    with LogWriter(tmp_path / "threads.mcap", logging_cfg(flush_interval_s=0.01), calibration=calib) as writer:
        def results():
            for seq in range(40):
                writer.write_result(make_result(seq), seq, CAMERA_TO_BASE)
                writer.write_diagnostics({"seq": seq})

        other = threading.Thread(target=results)
        other.start()
        for seq in range(40):
            writer.write_frame(make_frame(seq))
        other.join()
    summary = check_log(writer.path)
    assert summary.intact and summary.frames == 40
    assert summary.counts["/localize/result"] == summary.counts["/diagnostics"] == 40
    assert (writer.frames_written, writer.results_written, writer.diagnostics_written) == (40, 40, 40)
    assert [f.seq for f in iter_stereo_frames(writer.path)] == list(range(40))


def test_non_finite_numbers_are_valid_json_and_read_back_as_nan(tmp_path, calib):
    import dataclasses
    import math

    from appliance.logs import iter_messages

    result = make_result(1, n_branches=1)
    result = dataclasses.replace(result, features=(dataclasses.replace(result.features[0], radius_mm=math.nan,
                                                                       safe_depth_mm=math.inf),))
    with LogWriter(tmp_path / "nan.mcap", logging_cfg(), calibration=calib) as writer:
        writer.write_result(result, 1)
        writer.write_diagnostics({"temperature_c": float("nan"), "drops": np.int64(2)})
    assert writer.results_written == writer.diagnostics_written == 1

    def refuse(constant):
        raise ValueError(f"non-standard JSON constant {constant}")

    for _, message in iter_messages(writer.path, ("/localize/result", "/diagnostics")):
        json.loads(message.data, parse_constant=refuse)  # what a browser's JSON.parse accepts
    ((seq, _, logged),) = read_results(writer.path)
    assert seq == 1 and math.isnan(logged.features[0].radius_mm) and math.isnan(logged.features[0].safe_depth_mm)
    assert logged.branches[0].to_dict() == result.branches[0].to_dict()
    (diag,) = read_diagnostics(writer.path)
    assert diag["temperature_c"] is None and diag["drops"] == 2
