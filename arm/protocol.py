"""Wire protocol between the vision box and the arm controller (see ``arm/PROTOCOL.md``).

A frame on the wire is ``COBS(header + payload + crc) + 0x00``:

- header, 6 bytes little-endian: ``version u8, type u8, seq u16, length u16``
  (``length`` = payload bytes);
- ``crc``: CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, not reflected, xorout 0;
  check value of ``b"123456789"`` is 0x29B1) over header + payload, little-endian u16;
- COBS (Consistent Overhead Byte Stuffing) removes every 0x00, so 0x00 only ever
  delimits frames and a receiver resynchronises at the next 0x00 after noise.

Lengths travel as signed 16-bit integers in units of 0.25 mm (``LSB_MM``), range
+-8191.75 mm. Messages are the dataclasses :class:`Hello`, :class:`Obstacles`,
:class:`Heartbeat`, :class:`Ack` and :class:`Nack`; :func:`encode` turns one into
wire bytes, :class:`FrameDecoder` turns a byte stream back into :class:`Frame` s (or
:class:`DecodeError` s) and :func:`parse` a frame into its message.
:func:`obstacles_from_result` converts a localization result into the
:class:`Obstacles` message that fits a byte budget.
"""

from __future__ import annotations

import binascii
import math
import struct
from dataclasses import dataclass, field

import numpy as np

from appliance.errors import ApplianceError

PROTOCOL_VERSION = 1
LSB_MM = 0.25  # one unit of a length on the wire, mm
LSB_UM = 250  # the same in micrometres (announced in HELLO)
MAX_LENGTH_MM = 32767 * LSB_MM

HEADER = struct.Struct("<BBHH")  # version, type, seq, payload length
CRC = struct.Struct("<H")
MAX_PAYLOAD = 4096  # longer frames are rejected without being buffered further

# message types
HELLO, OBSTACLES, HEARTBEAT, ACK, NACK = 0x01, 0x02, 0x03, 0x10, 0x11
TYPE_NAMES = {HELLO: "HELLO", OBSTACLES: "OBSTACLES", HEARTBEAT: "HEARTBEAT", ACK: "ACK", NACK: "NACK"}

# NACK reasons
NACK_BAD_CRC, NACK_BAD_FRAME, NACK_UNKNOWN_TYPE, NACK_BAD_VERSION, NACK_BAD_LENGTH = 1, 2, 3, 4, 5
NACK_REASONS = {NACK_BAD_CRC: "bad_crc", NACK_BAD_FRAME: "bad_frame", NACK_UNKNOWN_TYPE: "unknown_type",
                NACK_BAD_VERSION: "bad_version", NACK_BAD_LENGTH: "bad_length"}
SEQ_UNKNOWN = 0xFFFF  # NACK of a frame whose sequence number could not be read

# OBSTACLES flags
FLAG_TRUNCATED = 0x01  # more segments were found than fit in one frame period
FLAG_OUT_OF_RANGE = 0x02  # segments beyond +-8191.75 mm were left out
# segment flags
SEG_RECOVERED = 0x01  # bridged across an occlusion rather than seen
# HEARTBEAT flags
HB_CAMERA_OK, HB_CALIBRATED, HB_ACK_MODE = 0x01, 0x02, 0x04

HELLO_FIXED = struct.Struct("<BHB")  # protocol version, LSB in um, version string length
OBSTACLES_FIXED = struct.Struct("<QIBBHH")  # stamp_ns, frame_seq, flags, reserved, count, total
SEGMENT = struct.Struct("<6hHHHBB")  # p0 xyz, p1 xyz, radius, clearance, branch_id, flags, reserved
HEARTBEAT_FIXED = struct.Struct("<QBBHI")  # stamp_ns, flags, reserved, rate (0.01 Hz), results dropped
ACK_FIXED = struct.Struct("<H")  # acknowledged seq
NACK_FIXED = struct.Struct("<HB")  # rejected seq, reason


class ProtocolError(ApplianceError):
    """A message cannot be encoded (value out of range) or a payload does not parse.

    ``reason`` is the NACK reason code a receiver answers with.
    """

    def __init__(self, message: str, reason: int = NACK_BAD_LENGTH):
        super().__init__(message)
        self.reason = reason


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (poly 0x1021, init 0xFFFF, no reflection, xorout 0)."""
    return binascii.crc_hqx(data, 0xFFFF)


def cobs_encode(data: bytes) -> bytes:
    """COBS-encode ``data``: no 0x00 in the result, at most ``len(data) // 254 + 1`` bytes longer."""
    out = bytearray()
    for piece in bytes(data).split(b"\0"):
        while len(piece) >= 254:
            out.append(0xFF)
            out += piece[:254]
            piece = piece[254:]
        out.append(len(piece) + 1)
        out += piece
    return bytes(out)


def cobs_decode(data: bytes) -> bytes:
    """Inverse of :func:`cobs_encode`; raises ``ValueError`` on a malformed block."""
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
        code = data[i]
        if code == 0 or i + code > n:
            raise ValueError("bad COBS block")
        block = data[i + 1:i + code]
        if 0 in block:
            raise ValueError("0x00 inside a COBS block")
        out += block
        i += code
        if code < 0xFF and i < n:
            out.append(0)
    return bytes(out)


# ---------------------------------------------------------------- messages


def _q(value_mm: float) -> int:
    """A length in mm as wire units (0.25 mm), rounded; ProtocolError beyond +-8191.75 mm."""
    q = round(float(value_mm) / LSB_MM)
    if not -32768 <= q <= 32767:
        raise ProtocolError(f"length {value_mm} mm is outside the wire range +-{MAX_LENGTH_MM} mm")
    return q


def _uq(value_mm: float, up: bool = False) -> int:
    """A non-negative length in mm as unsigned wire units (0.25 mm), at most 16383.75 mm.

    ``up``: round up (a clearance is never made smaller by the quantisation).
    """
    q = math.ceil(float(value_mm) / LSB_MM - 1e-9) if up else round(float(value_mm) / LSB_MM)
    if not 0 <= q <= 0xFFFF:
        raise ProtocolError(f"length {value_mm} mm is outside the wire range 0..{0xFFFF * LSB_MM} mm")
    return q


@dataclass(frozen=True)
class Hello:
    """Sent by the vision box after every (re)connection: protocol version, units, software version."""

    app_version: str = ""
    protocol_version: int = PROTOCOL_VERSION
    lsb_um: int = LSB_UM

    def payload(self) -> bytes:
        text = self.app_version.encode("utf-8")[:255]
        return HELLO_FIXED.pack(self.protocol_version, self.lsb_um, len(text)) + text

    @classmethod
    def from_payload(cls, p: bytes) -> Hello:
        version, lsb, n = HELLO_FIXED.unpack_from(p)
        _expect_length(p, HELLO_FIXED.size + n)
        return cls(p[HELLO_FIXED.size:].decode("utf-8", "replace"), version, lsb)


@dataclass(frozen=True)
class Segment:
    """One obstacle: a cylinder around the segment p0-p1 in the arm base frame.

    ``p0_mm``/``p1_mm`` (3,) mm, ``radius_mm`` the branch radius, ``clearance_mm`` the
    distance from the axis the arm must keep (safety factor x radius), ``branch_id`` the
    result's branch id, ``recovered`` True where the branch was bridged across an occlusion.
    """

    p0_mm: tuple[float, float, float]
    p1_mm: tuple[float, float, float]
    radius_mm: float
    clearance_mm: float
    branch_id: int = 0
    recovered: bool = False

    def pack(self) -> bytes:
        return SEGMENT.pack(*(_q(v) for v in (*self.p0_mm, *self.p1_mm)), _uq(self.radius_mm),
                            _uq(self.clearance_mm, up=True), self.branch_id & 0xFFFF,
                            SEG_RECOVERED if self.recovered else 0, 0)

    @classmethod
    def unpack(cls, p: bytes, offset: int) -> Segment:
        v = SEGMENT.unpack_from(p, offset)
        mm = [x * LSB_MM for x in v[:8]]
        return cls(tuple(mm[0:3]), tuple(mm[3:6]), mm[6], mm[7], v[8], bool(v[9] & SEG_RECOVERED))

    def to_dict(self) -> dict:
        return {"p0_mm": list(self.p0_mm), "p1_mm": list(self.p1_mm), "radius_mm": self.radius_mm,
                "clearance_mm": self.clearance_mm, "branch_id": self.branch_id,
                "recovered": self.recovered}


@dataclass(frozen=True)
class Obstacles:
    """The branches of one stereo frame as segments, nearest first.

    ``stamp_ns`` capture stamp of the frame, ``frame_seq`` its sequence number,
    ``total`` segments found (``len(segments)`` of them sent), ``truncated`` when
    the nearest ones only were sent because all did not fit one frame period,
    ``out_of_range`` when segments beyond the wire range were left out.
    """

    stamp_ns: int
    frame_seq: int
    segments: tuple[Segment, ...] = ()
    total: int = 0
    truncated: bool = False
    out_of_range: bool = False

    def payload(self) -> bytes:
        flags = (FLAG_TRUNCATED if self.truncated else 0) | (FLAG_OUT_OF_RANGE if self.out_of_range else 0)
        head = OBSTACLES_FIXED.pack(self.stamp_ns, self.frame_seq & 0xFFFFFFFF, flags, 0,
                                    len(self.segments), min(self.total, 0xFFFF))
        return head + b"".join(s.pack() for s in self.segments)

    @classmethod
    def from_payload(cls, p: bytes) -> Obstacles:
        stamp, frame_seq, flags, _, count, total = OBSTACLES_FIXED.unpack_from(p)
        _expect_length(p, OBSTACLES_FIXED.size + count * SEGMENT.size)
        segs = tuple(Segment.unpack(p, OBSTACLES_FIXED.size + i * SEGMENT.size) for i in range(count))
        return cls(stamp, frame_seq, segs, total, bool(flags & FLAG_TRUNCATED),
                   bool(flags & FLAG_OUT_OF_RANGE))

    def to_dict(self) -> dict:
        return {"stamp_ns": self.stamp_ns, "frame_seq": self.frame_seq, "total": self.total,
                "truncated": self.truncated, "out_of_range": self.out_of_range,
                "segments": [s.to_dict() for s in self.segments]}


@dataclass(frozen=True)
class Heartbeat:
    """About once a second: wall-clock ``stamp_ns``, status flags, result rate, drops so far."""

    stamp_ns: int
    camera_ok: bool
    calibrated: bool
    rate_hz: float
    ack_mode: bool = False
    results_dropped: int = 0

    def payload(self) -> bytes:
        flags = ((HB_CAMERA_OK if self.camera_ok else 0) | (HB_CALIBRATED if self.calibrated else 0)
                 | (HB_ACK_MODE if self.ack_mode else 0))
        rate = min(max(round(self.rate_hz * 100), 0), 0xFFFF) if math.isfinite(self.rate_hz) else 0
        return HEARTBEAT_FIXED.pack(self.stamp_ns, flags, 0, rate, min(self.results_dropped, 0xFFFFFFFF))

    @classmethod
    def from_payload(cls, p: bytes) -> Heartbeat:
        _expect_length(p, HEARTBEAT_FIXED.size)
        stamp, flags, _, rate, dropped = HEARTBEAT_FIXED.unpack(p)
        return cls(stamp, bool(flags & HB_CAMERA_OK), bool(flags & HB_CALIBRATED), rate / 100,
                   bool(flags & HB_ACK_MODE), dropped)


@dataclass(frozen=True)
class Ack:
    """From the controller: the frame with header sequence number ``seq`` arrived intact."""

    seq: int

    def payload(self) -> bytes:
        return ACK_FIXED.pack(self.seq)

    @classmethod
    def from_payload(cls, p: bytes) -> Ack:
        _expect_length(p, ACK_FIXED.size)
        return cls(*ACK_FIXED.unpack(p))


@dataclass(frozen=True)
class Nack:
    """From the controller: a frame was rejected (``seq`` 0xFFFF when unreadable); ``reason`` code."""

    seq: int
    reason: int

    def payload(self) -> bytes:
        return NACK_FIXED.pack(self.seq, self.reason)

    @classmethod
    def from_payload(cls, p: bytes) -> Nack:
        _expect_length(p, NACK_FIXED.size)
        return cls(*NACK_FIXED.unpack(p))


MESSAGE_TYPES = {Hello: HELLO, Obstacles: OBSTACLES, Heartbeat: HEARTBEAT, Ack: ACK, Nack: NACK}
Message = Hello | Obstacles | Heartbeat | Ack | Nack


def message_to_dict(message: Message) -> dict:
    """Plain dict of a message with its type name under ``"type"`` (tuples as lists)."""
    d = message.to_dict() if isinstance(message, Obstacles) else {
        k: getattr(message, k) for k in message.__dataclass_fields__}
    if isinstance(message, Nack):
        d["reason_name"] = NACK_REASONS.get(message.reason, "unknown")
    return {"type": TYPE_NAMES[MESSAGE_TYPES[type(message)]], **d}


def _expect_length(p: bytes, n: int) -> None:
    if len(p) != n:
        raise ProtocolError(f"payload is {len(p)} bytes, its fields say {n}")


# ---------------------------------------------------------------- frames


def encode(message: Message, seq: int) -> bytes:
    """Wire bytes of ``message`` with header sequence number ``seq`` (mod 2**16), 0x00 at the end."""
    payload = message.payload()
    body = HEADER.pack(PROTOCOL_VERSION, MESSAGE_TYPES[type(message)], seq & 0xFFFF, len(payload)) + payload
    return cobs_encode(body + CRC.pack(crc16(body))) + b"\0"


def wire_size(payload_bytes: int) -> int:
    """Largest number of wire bytes a frame with this payload can take (COBS worst case + 0x00)."""
    raw = HEADER.size + payload_bytes + CRC.size
    return raw + raw // 254 + 1 + 1


@dataclass(frozen=True)
class Frame:
    """A frame whose CRC checked: header fields and payload (``body`` = header + payload + crc)."""

    version: int
    type: int
    seq: int
    payload: bytes
    body: bytes = field(repr=False, default=b"")


@dataclass(frozen=True)
class DecodeError:
    """A rejected frame: ``reason`` one of NACK_REASONS' names, ``seq`` when the header was readable."""

    reason: str
    seq: int = SEQ_UNKNOWN
    size: int = 0


class FrameDecoder:
    """Incremental decoder: ``feed(bytes)`` returns the frames (and errors) completed so far.

    Never raises on any input. Bytes up to the next 0x00 are one frame; a frame
    longer than ``MAX_PAYLOAD`` plus overhead is dropped whole. Only frames whose
    CRC checks are returned as :class:`Frame`; everything else is a :class:`DecodeError`.
    Empty frames (consecutive 0x00) are ignored silently.
    """

    def __init__(self, max_payload: int = MAX_PAYLOAD):
        self._buf = bytearray()
        self._limit = wire_size(max_payload) - 1  # without the 0x00
        self._overflow = False

    def feed(self, data: bytes) -> list[Frame | DecodeError]:
        out: list[Frame | DecodeError] = []
        start = 0
        while True:
            end = data.find(0, start)
            chunk = data[start:] if end < 0 else data[start:end]
            if not self._overflow:
                self._buf += chunk
                if len(self._buf) > self._limit:
                    self._overflow = True
                    self._buf.clear()
            if end < 0:
                return out
            if self._overflow:
                out.append(DecodeError("bad_length"))
            elif self._buf:
                out.append(decode_frame(bytes(self._buf)))
            self._buf.clear()
            self._overflow = False
            start = end + 1


def decode_frame(encoded: bytes) -> Frame | DecodeError:
    """One frame between delimiters (COBS-encoded, without the 0x00) -> Frame or DecodeError."""
    try:
        body = cobs_decode(encoded)
    except ValueError:
        return DecodeError("bad_frame", size=len(encoded))
    if len(body) < HEADER.size + CRC.size:
        return DecodeError("bad_frame", size=len(encoded))
    if crc16(body[:-CRC.size]) != CRC.unpack_from(body, len(body) - CRC.size)[0]:
        return DecodeError("bad_crc", size=len(encoded))
    version, mtype, seq, length = HEADER.unpack_from(body)
    if version != PROTOCOL_VERSION:
        return DecodeError("bad_version", seq, len(encoded))
    if length != len(body) - HEADER.size - CRC.size:
        return DecodeError("bad_length", seq, len(encoded))
    return Frame(version, mtype, seq, body[HEADER.size:-CRC.size], body)


_PARSERS = {code: cls for cls, code in MESSAGE_TYPES.items()}


def parse(frame: Frame) -> Message:
    """The message in a frame; ProtocolError for an unknown type or a payload that does not parse."""
    cls = _PARSERS.get(frame.type)
    if cls is None:
        raise ProtocolError(f"unknown message type 0x{frame.type:02x}", NACK_UNKNOWN_TYPE)
    try:
        return cls.from_payload(frame.payload)
    except struct.error as exc:
        name = TYPE_NAMES[frame.type]
        raise ProtocolError(f"{name} payload of {len(frame.payload)} bytes: {exc}") from None


def nack_reason(error: DecodeError | ProtocolError) -> int:
    """NACK reason code for a decode error or a parse error."""
    if isinstance(error, DecodeError):
        return {v: k for k, v in NACK_REASONS.items()}[error.reason]
    return error.reason


# ---------------------------------------------------------------- results -> obstacles


def budget_bytes(baud: int, frame_rate_hz: float) -> int:
    """Wire bytes one OBSTACLES frame may take: what 8N1 at ``baud`` carries in one frame period.

    8N1 sends 10 bits per byte, so ``baud / 10 / frame_rate_hz`` bytes per period, less
    one HEARTBEAT frame (26 bytes) that may share the period. 115200 Bd at 30 Hz: 358.
    """
    return int(baud / 10 / frame_rate_hz) - wire_size(HEARTBEAT_FIXED.size)


def max_segments(max_bytes: int) -> int:
    """Most segments whose OBSTACLES frame stays within ``max_bytes`` on the wire (worst-case COBS).

    Never more than fit a payload of ``MAX_PAYLOAD`` (4096) bytes: 203.
    """
    n = max(0, (max_bytes - wire_size(OBSTACLES_FIXED.size)) // SEGMENT.size + 1)
    while n > 0 and wire_size(OBSTACLES_FIXED.size + n * SEGMENT.size) > max_bytes:
        n -= 1
    return min(n, (MAX_PAYLOAD - OBSTACLES_FIXED.size) // SEGMENT.size)


def simplify_polyline(points_mm: np.ndarray, tolerance_mm: float) -> np.ndarray:
    """Ramer-Douglas-Peucker: keep the fewest vertices with every point within ``tolerance_mm``.

    ``points_mm`` (N, 3) -> (M, 3), M <= N, first and last vertex kept.
    """
    pts = np.asarray(points_mm, float).reshape(-1, 3)
    if len(pts) < 3 or tolerance_mm <= 0:
        return pts
    keep = np.zeros(len(pts), bool)
    keep[[0, -1]] = True
    stack = [(0, len(pts) - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        d = _point_segment_distance(pts[a + 1:b], pts[a], pts[b])
        i = int(np.argmax(d))
        if d[i] > tolerance_mm:
            keep[a + 1 + i] = True
            stack += [(a, a + 1 + i), (a + 1 + i, b)]
    return pts[keep]


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances (K,) of points ``p`` (K, 3) from the segment a-b (each (3,))."""
    ab, ap = b - a, p - a
    denom = float(ab @ ab)
    if denom > 0:
        t = np.minimum(np.maximum(ap @ ab / denom, 0.0), 1.0)
        ap = ap - t[:, None] * ab
    return np.sqrt(np.einsum("ij,ij->i", ap, ap))


def safety_factor(result, default: float = 1.05) -> float:
    """The safety factor k the localizer used (Z - safe_depth = k * radius), median over features."""
    ks = [(f.xyz_mm[2] - f.safe_depth_mm) / f.radius_mm for f in result.features
          if f.radius_mm > 0 and math.isfinite(f.safe_depth_mm) and math.isfinite(f.xyz_mm[2])]
    return float(np.median(ks)) if ks else default


def obstacles_from_result(result, camera_to_base, max_bytes: int, *, frame_seq: int = 0,
                          tolerance_mm: float = 1.0) -> Obstacles:
    """The OBSTACLES message of a localization result, nearest segments first, within ``max_bytes``.

    Parameters
    ----------
    result : appliance.localize.result.LocalizationResult
        Branches with ``polyline_mm`` (N, 3) in the camera frame and ``radius_mm``.
    camera_to_base : array_like (4, 4)
        p_base = camera_to_base @ [X, Y, Z, 1] (mm).
    max_bytes : int
        Wire bytes the frame may take (see :func:`budget_bytes`); the nearest segments
        that fit are sent and ``truncated`` is set when some did not.
    frame_seq : int
        The frame's sequence number.
    tolerance_mm : float
        Each polyline is simplified (Ramer-Douglas-Peucker) so no axis point is further
        than this from its segment.

    Nearest means smallest distance from the arm base origin to the segment's
    surface (distance to the axis segment minus the clearance, at least 0). Branches
    beyond the wire range (+-8191.75 mm) or with non-finite values are left out and
    ``out_of_range`` is set.
    """
    T = np.asarray(camera_to_base, float).reshape(4, 4)
    k = safety_factor(result)
    p0, p1, rows, out_of_range = [], [], [], False  # rows: (radius, clearance, branch id, recovered)
    for br in result.branches:
        poly = simplify_polyline(br.polyline_mm, tolerance_mm)
        if len(poly) == 0:
            continue
        if len(poly) == 1:
            poly = np.vstack([poly, poly])
        base = poly @ T[:3, :3].T + T[:3, 3]
        clearance = k * float(br.radius_mm)
        if not (np.abs(base).max() <= MAX_LENGTH_MM and 0 <= clearance <= 0xFFFF * LSB_MM):
            out_of_range = True  # also NaN / inf / negative radius: left out, flagged
            continue
        p0.append(base[:-1])
        p1.append(base[1:])
        rows += [(float(br.radius_mm), clearance, int(br.id), bool(br.recovered))] * (len(base) - 1)
    if not rows:
        return Obstacles(int(result.stamp_ns), int(frame_seq), (), 0, False, out_of_range)
    a, b = np.concatenate(p0), np.concatenate(p1)
    # distance of the origin from each segment a-b, less the clearance
    ab = b - a
    t = np.clip(-np.einsum("ij,ij->i", a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12), 0, 1)
    dist = np.maximum(np.linalg.norm(a + t[:, None] * ab, axis=1) - [r[1] for r in rows], 0)
    n = max_segments(max_bytes)
    chosen = tuple(Segment(tuple(a[i].tolist()), tuple(b[i].tolist()), *rows[i])
                   for i in np.argsort(dist, kind="stable")[:n])
    return Obstacles(int(result.stamp_ns), int(frame_seq), chosen, len(rows), len(rows) > n, out_of_range)
