"""Encode/decode of the arm protocol: round trips, hostile byte streams, test vectors."""

from __future__ import annotations

import json

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from appliance.arm import make_test_vectors
from appliance.arm import protocol as P
from appliance.localize.result import Branch, Feature, LocalizationResult

# lengths on the wire grid (0.25 mm) so round trips are exact
coord = st.integers(-32768, 32767).map(lambda q: q * P.LSB_MM)
ulen = st.integers(0, 0xFFFF).map(lambda q: q * P.LSB_MM)
u16 = st.integers(0, 0xFFFF)
segments = st.builds(P.Segment, st.tuples(coord, coord, coord), st.tuples(coord, coord, coord), ulen, ulen,
                     u16, st.booleans())
messages = st.one_of(
    st.builds(P.Hello, st.text(max_size=40).filter(lambda s: len(s.encode()) <= 255),
              st.integers(0, 255), u16),
    st.builds(P.Obstacles, st.integers(0, 2**64 - 1), st.integers(0, 2**32 - 1),
              st.lists(segments, max_size=20).map(tuple), u16, st.booleans(), st.booleans()),
    st.builds(P.Heartbeat, st.integers(0, 2**64 - 1), st.booleans(), st.booleans(),
              u16.map(lambda r: r / 100), st.booleans(), st.integers(0, 2**32 - 1)),
    st.builds(P.Ack, u16),
    st.builds(P.Nack, u16, st.integers(0, 255)),
)


def decode_all(data: bytes, chunk: int = 0) -> list:
    dec = P.FrameDecoder()
    if chunk <= 0:
        return dec.feed(data)
    out = []
    for i in range(0, len(data), chunk):
        out += dec.feed(data[i:i + chunk])
    return out


def test_crc_variant_check_value():
    # CRC-16/CCITT-FALSE catalogue check value
    assert P.crc16(b"123456789") == 0x29B1


@given(st.binary(max_size=1200))
def test_cobs_round_trip_has_no_zero(data):
    enc = P.cobs_encode(data)
    assert 0 not in enc
    assert len(enc) <= len(data) + len(data) // 254 + 1
    assert P.cobs_decode(enc) == data


@given(messages, u16, st.integers(1, 64))
def test_message_round_trip(message, seq, chunk):
    wire = P.encode(message, seq)
    assert wire.endswith(b"\0") and 0 not in wire[:-1]
    (frame,) = decode_all(wire, chunk)
    assert isinstance(frame, P.Frame)
    assert frame.seq == seq and frame.type == P.MESSAGE_TYPES[type(message)]
    assert P.parse(frame) == message
    assert len(wire) <= P.wire_size(len(frame.payload))


@settings(max_examples=300)
@given(st.binary(max_size=3000), st.integers(1, 97))
def test_random_bytes_never_crash_nor_yield_bad_crc(data, chunk):
    for item in decode_all(data, chunk):
        assert isinstance(item, (P.Frame, P.DecodeError))
        if isinstance(item, P.Frame):
            body = item.body
            assert P.crc16(body[:-2]) == int.from_bytes(body[-2:], "little")
            try:
                P.parse(item)
            except P.ProtocolError:
                pass


@settings(max_examples=200, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(messages, u16), min_size=2, max_size=6), st.data())
def test_corruption_loses_only_the_touched_frames(items, data):
    wires = [P.encode(m, s) for m, s in items]
    stream = bytearray(b"".join(wires))
    ends = np.cumsum([len(w) for w in wires])  # index after each frame's 0x00
    flips = data.draw(st.lists(st.tuples(st.integers(0, len(stream) - 1), st.integers(1, 255)),
                               min_size=1, max_size=3, unique_by=lambda f: f[0]))
    touched = set()
    for pos, xor in flips:
        stream[pos] ^= xor
        i = int(np.searchsorted(ends, pos, side="right"))
        touched.add(i)
        if stream[pos] != 0 and pos == ends[i] - 1:  # a delimiter lost: the next frame merges in
            touched.add(i + 1)
    frames = [f for f in decode_all(bytes(stream)) if isinstance(f, P.Frame)]
    decoded = [(f.seq, P.parse(f)) for f in frames]
    expected = [(s, m) for j, (m, s) in enumerate(items) if j not in touched]
    # every untouched frame survives, in order, and no touched one gets through
    assert decoded == expected


def test_oversized_frame_is_dropped_and_decoder_resyncs():
    dec = P.FrameDecoder(max_payload=64)
    good = P.encode(P.Ack(5), 1)
    out = dec.feed(b"\x01" * 500 + b"\0" + good)
    assert isinstance(out[0], P.DecodeError) and out[0].reason == "bad_length"
    assert P.parse(out[1]) == P.Ack(5)


def test_vectors_file_is_what_the_generator_writes():
    assert json.loads(make_test_vectors.PATH.read_text()) == make_test_vectors.vectors()


def test_vectors_decode_as_documented():
    doc = json.loads(make_test_vectors.PATH.read_text())
    assert P.crc16(doc["crc"]["input_ascii"].encode()) == int(doc["crc"]["check"], 16)
    for c in doc["cobs"]:
        assert P.cobs_decode(bytes.fromhex(c["encoded"])) == bytes.fromhex(c["decoded"])
    assert len(doc["frames"]) >= 7
    for v in doc["frames"]:
        (frame,) = P.FrameDecoder().feed(bytes.fromhex(v["hex"]))
        assert frame.body.hex() == v["body_hex"]
        h = v["header"]
        assert (frame.version, frame.type, frame.seq, len(frame.payload)) == (
            h["version"], h["type"], h["seq"], h["length"])
        assert P.TYPE_NAMES[frame.type] == h["type_name"]
        assert int(v["crc"], 16) == P.crc16(frame.body[:-2])
        assert P.message_to_dict(P.parse(frame)) == v["message"], v["name"]
    for v in doc["invalid"]:
        (err,) = P.FrameDecoder().feed(bytes.fromhex(v["hex"]))
        assert isinstance(err, P.DecodeError) and err.reason == v["error"], v["name"]


def test_truncated_vector_is_one_frame_period_at_default_baud():
    doc = json.loads(make_test_vectors.PATH.read_text())
    (v,) = [v for v in doc["frames"] if v["name"] == "obstacles_truncated"]
    budget = P.budget_bytes(115200, 30.0)
    assert budget == 358 and P.max_segments(budget) == 16
    assert len(bytes.fromhex(v["hex"])) <= budget
    assert v["message"]["truncated"] and len(v["message"]["segments"]) == 16


def _branch(i, pts, r=5.0, recovered=False):
    return Branch(i, (-1, -1), np.asarray(pts, float), r, recovered)


def test_obstacles_from_result_transforms_sorts_and_truncates():
    # a straight branch far away and a bent one near; translation of the base 100 mm in x
    far = _branch(1, [[0, 0, 1400], [0, 100, 1400], [0, 200, 1400]], 8.0)
    near = _branch(2, [[0, 0, 600], [50, 0, 600], [50, 50, 600]], 4.0, recovered=True)
    feat = Feature(0, "endpoint", (0, 0), (0, 0), (0, 0, 600), 4.0, 600 - 1.05 * 4.0)
    result = LocalizationResult((feat,), (far, near), stamp_ns=77)
    T = np.eye(4)
    T[0, 3] = 100.0
    obs = P.obstacles_from_result(result, T, 10_000, frame_seq=9)
    assert (obs.stamp_ns, obs.frame_seq, obs.total, obs.truncated) == (77, 9, 3, False)
    # the straight far polyline simplifies to one segment; the near one keeps its corner
    assert [s.branch_id for s in obs.segments] == [2, 2, 1]
    assert obs.segments[0].recovered and not obs.segments[2].recovered
    assert np.allclose(obs.segments[2].p0_mm, (100, 0, 1400))
    assert np.allclose(obs.segments[2].p1_mm, (100, 200, 1400))
    assert np.isclose(obs.segments[0].clearance_mm, 1.05 * 4.0)
    d = [np.linalg.norm(s.p0_mm) for s in obs.segments]
    assert d[0] < d[2]
    one = P.wire_size(P.OBSTACLES_FIXED.size + P.SEGMENT.size)
    small = P.obstacles_from_result(result, T, one, frame_seq=9)
    assert small.truncated and small.total == 3 and small.segments == obs.segments[:1]
    wire = P.encode(small, 0)
    assert len(wire) <= one


def test_obstacles_out_of_wire_range_are_left_out():
    far, near = _branch(1, [[0, 0, 9000], [0, 10, 9000]]), _branch(2, [[0, 0, 800], [0, 9, 800]])
    result = LocalizationResult((), (far, near))
    obs = P.obstacles_from_result(result, np.eye(4), 10_000)
    assert obs.out_of_range and obs.total == 1 and [s.branch_id for s in obs.segments] == [2]
    assert P.parse(P.FrameDecoder().feed(P.encode(obs, 1))[0]).out_of_range


def test_simplify_keeps_points_within_tolerance():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, 200)
    pts = np.c_[300 * t, 40 * np.sin(6 * t), 900 + rng.normal(0, 0.2, t.size)]
    simple = P.simplify_polyline(pts, 1.0)
    assert 3 <= len(simple) < 40
    d = np.min([P._point_segment_distance(pts, a, b) for a, b in zip(simple[:-1], simple[1:])], axis=0)
    assert d.max() <= 1.0 + 1e-9


def test_protocol_document_bandwidth_table_matches_the_code():
    doc = (make_test_vectors.PATH.parent / "PROTOCOL.md").read_text()
    table = doc[doc.index("| baud | 10 Hz |"):].split("\n\n")[0].splitlines()[2:]
    rows = [line.split("|")[1:-1] for line in table]
    assert len(rows) == 5
    for row in rows:
        baud, *counts = (int(c) for c in row)
        assert counts == [P.max_segments(P.budget_bytes(baud, hz)) for hz in (10, 15, 30)], baud
    assert P.wire_size(P.HEARTBEAT_FIXED.size) == 26 and "358 byte" in doc
    assert P.wire_size(P.MAX_PAYLOAD) - 1 == 4121 and "4121 bytes before its 0x00" in doc


def test_quantisation_rounds_lengths_and_never_shrinks_clearance():
    seg = P.Segment((1.1, -2.2, 1000.13), (0.0, 0.0, 0.0), 2.61, 2.7405)
    (frame,) = P.FrameDecoder().feed(P.encode(P.Obstacles(0, 0, (seg,), 1), 0))
    (back,) = P.parse(frame).segments
    assert np.allclose(back.p0_mm, seg.p0_mm, atol=P.LSB_MM / 2) and abs(back.radius_mm - 2.61) <= 0.125
    assert seg.clearance_mm <= back.clearance_mm < seg.clearance_mm + P.LSB_MM


def test_non_finite_branches_are_left_out_not_fatal():
    bad = _branch(1, [[0, 0, np.nan], [0, 10, 900]])
    inf_r = _branch(2, [[0, 0, 900], [0, 10, 900]], r=np.inf)
    good = _branch(3, [[0, 0, 800], [0, 9, 800]])
    obs = P.obstacles_from_result(LocalizationResult((), (bad, inf_r, good)), np.eye(4), 10_000)
    assert obs.out_of_range and [s.branch_id for s in obs.segments] == [3]
    hb = P.Heartbeat(0, True, True, float("nan"))
    assert P.parse(P.FrameDecoder().feed(P.encode(hb, 0))[0]).rate_hz == 0.0
