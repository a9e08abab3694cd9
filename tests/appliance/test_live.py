"""LiveServer: a real Foxglove WebSocket server on loopback and a real WebSocket client."""

from __future__ import annotations

import base64
import json
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap.reader import make_reader
from websockets.sync.client import connect

from appliance.acquire import StereoFrame
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.live import LiveError, LiveServer
from appliance.localize.result import Branch, Feature, LocalizationResult
from appliance.logs import LogWriter
from appliance.logs import messages as m
from appliance.logs.images import decode_image

RIG = Path(__file__).resolve().parents[2] / "fixtures" / "rig.yaml"
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]   # what the Foxglove app offers
T0_NS = 1_790_000_000_000_000_000
CAMERA_TO_BASE = np.array([[0.0, 0.0, 1.0, 100.0], [-1.0, 0.0, 0.0, 20.0], [0.0, -1.0, 0.0, 500.0],
                           [0.0, 0.0, 0.0, 1.0]])


def make_frame(seq: int, width: int = 1280, height: int = 960) -> StereoFrame:
    rng = np.random.default_rng(seq)
    small = rng.integers(0, 256, (height // 16, width // 16, 3), np.uint8)
    left = np.repeat(np.repeat(small, 16, axis=0), 16, axis=1)
    return StereoFrame(left, np.roll(left, 9, axis=1), seq, T0_NS + seq * 33_333_333, T0_NS + seq * 33_333_333 + 250_000)


def make_result(seq: int) -> LocalizationResult:
    z = 900.0 + seq
    features = (Feature(0, "endpoint", (10.0, 20.5), (3.25, 20.5), (0.0, -5.0, z), 4.0, z - 4.2),
                Feature(1, "bifurcation", (110.0, 220.5), (93.5, 220.5), (50.0, 35.0, z + 8), 6.0, z + 8 - 6.3))
    branches = (Branch(0, (0, 1), np.array([[0.0, -5.0, z], [25.0, 15.0, z + 4], [50.0, 35.0, z + 8]]), 5.0),)
    return LocalizationResult(features, branches, T0_NS + seq * 33_333_333 + 125_000, {"segment": 1.5})


class Client:
    """A Foxglove WebSocket client: reads serverInfo and the advertised channels, subscribes,
    decodes binary messageData with the advertised schemas."""

    def __init__(self, url: str, max_queue: int = 16):
        self._connection = connect(url, subprotocols=SUBPROTOCOLS, max_size=None, open_timeout=5, close_timeout=1,
                                   max_queue=max_queue)
        self.ws = self._connection.__enter__()
        self.server_info = self.json()
        self.channels: dict[str, dict] = {}
        while len(self.channels) < len(m.PROTOBUF_TOPICS) + len(m.JSON_TOPICS):
            op = self.json()
            assert op["op"] == "advertise", op
            self.channels.update({c["topic"]: c for c in op["channels"]})
        self.subscriptions: dict[int, str] = {}

    def json(self) -> dict:
        return json.loads(self.ws.recv(timeout=5))

    def subscribe(self, *topics: str) -> None:
        subs = [{"id": 10 + len(self.subscriptions) + i, "channelId": self.channels[t]["id"]} for i, t in enumerate(topics)]
        self.subscriptions.update({s["id"]: t for s, t in zip(subs, topics)})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def message(self) -> tuple[str, int, bytes]:
        """The next messageData: (topic, log time ns, payload)."""
        while True:
            data = self.ws.recv(timeout=5)
            if isinstance(data, bytes):
                break
        opcode, sub_id, stamp_ns = struct.unpack_from("<BIQ", data)
        assert opcode == 1
        return self.subscriptions[sub_id], stamp_ns, data[13:]

    def protobuf_class(self, topic: str):
        """The message class built from the schema the server advertised (not from our imports)."""
        channel = self.channels[topic]
        fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
        pool = descriptor_pool.DescriptorPool()
        for f in fds.file:
            pool.Add(f)
        return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc) -> None:
        self._connection.__exit__(*exc)


def wait_subscribed(server: LiveServer, *topics: str) -> None:
    deadline = time.monotonic() + 5
    while not set(topics) <= set(server.subscribed_topics()):
        assert time.monotonic() < deadline, f"not subscribed: {topics}"
        time.sleep(0.01)


@pytest.fixture
def server():
    with LiveServer("127.0.0.1", 0, calibration=load_calibration(RIG), jpeg_quality=80) as srv:
        yield srv


def test_channels_are_the_logs_topics_and_schemas(server):
    with Client(server.url) as client:
        assert server.port > 0 and server.url == f"ws://127.0.0.1:{server.port}"
        assert client.server_info["op"] == "serverInfo"
        assert client.server_info["name"] == "appliance"
        assert client.ws.subprotocol in SUBPROTOCOLS
        expected = {t: ("protobuf", cls.DESCRIPTOR.full_name) for t, cls in m.PROTOBUF_TOPICS.items()}
        expected.update({t: ("json", s["title"]) for t, s in m.JSON_TOPICS.items()})
        got = {t: (c["encoding"], c["schemaName"]) for t, c in client.channels.items()}
        assert got == expected
        assert got[m.LEFT_IMAGE] == ("protobuf", "foxglove.CompressedImage")
        assert json.loads(client.channels[m.RESULT]["schema"]) == m.RESULT_SCHEMA


def test_frame_result_and_diagnostics_arrive_as_in_the_log(server):
    with Client(server.url) as client:
        client.subscribe(m.RESULT, m.LEFT_IMAGE, m.BRANCHES, m.DIAGNOSTICS)
        wait_subscribed(server, m.RESULT, m.LEFT_IMAGE, m.BRANCHES, m.DIAGNOSTICS)
        frame, result = make_frame(7), make_result(7)
        assert server.write_frame(frame)
        assert server.write_result(result, 7, CAMERA_TO_BASE)
        assert server.write_diagnostics({"rate_hz": 29.5, "dropped_log": 0}, T0_NS)
        got = {}
        while len(got) < 4:
            topic, stamp_ns, payload = client.message()
            got[topic] = (stamp_ns, payload)

        stamp_ns, payload = got[m.RESULT]
        assert stamp_ns == result.stamp_ns
        assert json.loads(payload) == json.loads(json.dumps({**result.to_dict(), "seq": 7}))

        stamp_ns, payload = got[m.LEFT_IMAGE]
        image = client.protobuf_class(m.LEFT_IMAGE).FromString(payload)
        assert stamp_ns == frame.stamp_left_ns and image.frame_id == m.CAMERA_FRAME and image.format == "jpeg"
        decoded = decode_image(image.data)
        assert decoded.shape == frame.left.shape
        assert np.abs(decoded.astype(int) - frame.left).mean() < 6      # JPEG of the left image

        scene = client.protobuf_class(m.BRANCHES).FromString(got[m.BRANCHES][1])
        assert len(scene.entities[0].cylinders) == 2                       # a 3-point polyline
        assert scene.entities[0].cylinders[0].size.x == pytest.approx(0.010)  # diameter 10 mm, in m

        diagnostics = json.loads(got[m.DIAGNOSTICS][1])
        assert diagnostics["rate_hz"] == 29.5 and diagnostics["stamp_ns"] == T0_NS
        assert diagnostics["live"]["results_sent"] == 1
        assert m.RIGHT_IMAGE not in got                                    # not subscribed: not sent


def test_calibration_is_repeated_for_a_client_that_subscribes_late():
    calib = load_calibration(RIG)
    with LiveServer("127.0.0.1", 0, calibration=calib, calibration_period_s=0.3) as server, \
            Client(server.url) as client:
        client.subscribe(m.LEFT_IMAGE)
        wait_subscribed(server, m.LEFT_IMAGE)
        assert server.write_frame(make_frame(1))                 # calibration due, nobody wants it
        assert client.message()[0] == m.LEFT_IMAGE
        client.subscribe(m.LEFT_CALIBRATION)
        wait_subscribed(server, m.LEFT_CALIBRATION)
        assert server.write_frame(make_frame(2))                 # within the period: images only
        assert client.message()[0] == m.LEFT_IMAGE
        time.sleep(0.3)
        frame = make_frame(3)
        assert server.write_frame(frame)
        topic, stamp_ns, payload = client.message()
        assert (topic, stamp_ns) == (m.LEFT_CALIBRATION, frame.stamp_left_ns)
        calibration = client.protobuf_class(topic).FromString(payload)
        assert (calibration.width, calibration.height) == calib.image_size
        assert calibration.K == pytest.approx(calib.K1.ravel())
        assert client.message()[0] == m.LEFT_IMAGE
        assert server.frames_sent == 3 and server.errors == 0


def test_a_client_that_never_reads_does_not_block_the_caller(server):
    with Client(server.url, max_queue=1) as stalled:      # stops reading the socket at once
        stalled.subscribe(m.LEFT_IMAGE, m.RIGHT_IMAGE)
        wait_subscribed(server, m.LEFT_IMAGE, m.RIGHT_IMAGE)
        frame = make_frame(3)
        worst_s = 0.0
        for _ in range(150):                                 # ~150 x 2 JPEGs of 1280x960 noise
            t0 = time.perf_counter()
            assert server.write_frame(frame)
            worst_s = max(worst_s, time.perf_counter() - t0)
        assert worst_s < 0.25                                # no wait for the client (or the JPEGs)
        with Client(server.url) as other:                    # the server still answers others
            assert other.server_info["op"] == "serverInfo"
        t0 = time.perf_counter()
        server.close()
        assert time.perf_counter() - t0 < 5
    assert server.frames_dropped > 0                         # the worker could not keep up: newest won
    assert server.frames_sent + server.frames_dropped == 150
    assert server.errors == 0


def test_without_a_client_nothing_is_built_or_counted(server):
    assert not server.write_frame(make_frame(1))
    assert not server.write_result(make_result(1), 1, CAMERA_TO_BASE)
    assert server.stats()["frames_sent"] == server.stats()["frames_dropped"] == server.results_sent == 0


def test_port_in_use_is_a_one_line_error():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(LiveError, match=f"127.0.0.1:{port}: cannot start the live server") as err:
            LiveServer("127.0.0.1", port)
        assert "\n" not in str(err.value)


def test_without_foxglove_sdk_the_error_says_how_to_install():
    code = ("import sys; sys.modules['foxglove'] = None\n"
            "from appliance.live import LiveServer, LiveError\n"
            "try:\n    LiveServer('127.0.0.1', 0)\nexcept LiveError as exc:\n    print(exc)\n")
    out = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "the live view needs foxglove-sdk: pip install 'appliance[live]'"


def test_every_topic_carries_the_bytes_the_log_has(tmp_path):
    """Same inputs through LogWriter and LiveServer: every message but /diagnostics is identical."""
    calib = load_calibration(RIG)
    cfg = load_config(overrides={"logging": {"image_encoding": "jpeg", "jpeg_quality": 75}}).logging
    frame, result = make_frame(5), make_result(5)
    with LogWriter(tmp_path / "run.mcap", cfg, calibration=calib) as writer:
        writer.write_frame(frame)
        writer.write_result(result, 5, CAMERA_TO_BASE)
    with open(tmp_path / "run.mcap", "rb") as f:
        logged = {ch.topic: (msg.log_time, msg.data) for _, ch, msg in make_reader(f).iter_messages()}
    assert set(logged) == set(m.PROTOBUF_TOPICS) | {m.RESULT}

    with LiveServer("127.0.0.1", 0, calibration=calib, image_encoding=cfg.image_encoding,
                    jpeg_quality=cfg.jpeg_quality) as server, Client(server.url) as client:
        client.subscribe(*logged)
        wait_subscribed(server, *logged)
        assert server.write_frame(frame)
        assert server.write_result(result, 5, CAMERA_TO_BASE)
        live = {}
        while len(live) < len(logged):
            topic, stamp_ns, payload = client.message()
            live[topic] = (stamp_ns, payload)
    assert live == logged


def test_appliance_run_live_streams_results(tmp_path):
    """`appliance run --live` as a real process: a client sees results while it runs; SIGINT ends it."""
    import signal

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    scenes = RIG.parent / "scenes"
    cfg = tmp_path / "loop.yaml"
    cfg.write_text("camera:\n  fake_loop: true\n  fake_rate_hz: 10.0\n")
    proc = subprocess.Popen([str(Path(sys.executable).with_name("appliance")), "run", "--device", f"fake:{scenes}",
                             "--calib", str(RIG), "--no-log", "--live", "--live-port", str(port), "-q",
                             "--config", str(cfg)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                client = Client(f"ws://127.0.0.1:{port}")
                break
            except OSError:
                assert proc.poll() is None, proc.communicate()[1]
                assert time.monotonic() < deadline, "the live server never came up"
                time.sleep(0.2)
        client.subscribe(m.RESULT)
        topic, _stamp_ns, payload = client.message()
        assert topic == m.RESULT
        result = json.loads(payload)
        assert result["features"] and result["branches"] and result["seq"] >= 0
        client.__exit__(None, None, None)
    finally:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "localized" in out
