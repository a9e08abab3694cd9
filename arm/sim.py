"""A stand-in for the arm controller: decodes frames, checks CRCs, ACKs/NACKs, injects faults.

:class:`ArmSim` opens a serial port with pyserial (a real one, or a pseudo-terminal),
decodes every frame, answers OBSTACLES and HELLO with ACK and rejected frames with NACK
(reason code, sequence number when readable), and reports each message through
``on_event`` (a dict per event: ``{"event": "message", "type": "OBSTACLES", "seq": ..., ...}``
or ``{"event": "error", "reason": "bad_crc", ...}``). A port that vanishes is reopened.

Faults (:class:`Faults`) play a bad line or a busy controller:

- ``drop``: probability a received frame is ignored, as if lost on the wire (no answer);
- ``corrupt``: probability one byte of a received frame is flipped before decoding
  (the CRC then fails and the frame is NACKed);
- ``delay_s``: every answer is sent this late;
- ``disconnect_s``: every this many seconds the port is closed for ``disconnect_for_s``
  (``--fault disconnect=EVERY[/FOR]``, default 5 s / 1 s).
"""

from __future__ import annotations

import random
import threading
import time
from dataclasses import dataclass
from typing import Callable

import serial

from appliance.arm import protocol as P
from appliance.arm.link import port_error
from appliance.errors import ApplianceError


class ArmSimError(ApplianceError):
    """The simulator's port cannot be opened, or a fault is malformed."""


@dataclass(frozen=True)
class Faults:
    drop: float = 0.0
    corrupt: float = 0.0
    delay_s: float = 0.0
    disconnect_s: float = 0.0
    disconnect_for_s: float = 1.0
    seed: int = 0


FAULT_DEFAULTS = {"drop": 0.1, "corrupt": 0.1, "delay": 0.2, "disconnect": 5.0}


def parse_faults(specs: list[str], seed: int = 0) -> Faults:
    """``["drop=0.2", "delay", "disconnect=5/1"]`` -> Faults; a bare name takes its default."""
    values, off_s = {}, 1.0
    for spec in specs:
        name, _, value = spec.partition("=")
        if name == "disconnect" and "/" in value:
            value, _, off = value.partition("/")
            try:
                off_s = float(off)
            except ValueError:
                raise ArmSimError(f"--fault {spec}: {off!r} is not a number") from None
        if name not in FAULT_DEFAULTS:
            raise ArmSimError(f"--fault {spec}: unknown fault, expected one of {', '.join(FAULT_DEFAULTS)}")
        try:
            values[name] = float(value) if value else FAULT_DEFAULTS[name]
        except ValueError:
            raise ArmSimError(f"--fault {spec}: {value!r} is not a number") from None
        if values[name] < 0 or (name in ("drop", "corrupt") and values[name] > 1):
            raise ArmSimError(f"--fault {spec}: out of range (probabilities 0..1, times >= 0)")
    return Faults(values.get("drop", 0.0), values.get("corrupt", 0.0), values.get("delay", 0.0),
                  values.get("disconnect", 0.0), off_s, seed)


def open_port(port: str, baud: int) -> serial.Serial:
    """The port opened with pyserial (non-blocking reads); ArmSimError naming it if missing."""
    try:
        return serial.Serial(port, baud, timeout=0, write_timeout=1.0)
    except serial.SerialException as exc:
        raise ArmSimError(f"serial port {port}: cannot open ({port_error(exc)})") from None


class ArmSim:
    """The simulated controller on ``port`` (see the module docstring)."""

    def __init__(self, port: str, baud: int = 115200, faults: Faults = Faults(),
                 on_event: Callable[[dict], None] = lambda e: None):
        self.port_name, self.baud, self.faults, self.on_event = port, baud, faults, on_event
        self.rng = random.Random(faults.seed)
        self.counts = {"frames": 0, "obstacles": 0, "errors": 0, "acks": 0, "nacks": 0, "dropped": 0,
                       "corrupted": 0, "disconnects": 0}
        self._seq = 0
        self._answers: list[tuple[float, bytes]] = []

    def run(self, stop: threading.Event, duration_s: float | None = None) -> dict:
        """Serve until ``stop`` is set (or ``duration_s`` passed); returns the counts."""
        port = open_port(self.port_name, self.baud)
        self.on_event({"event": "port_open", "port": self.port_name})
        decoder = P.FrameDecoder()
        start = time.monotonic()
        next_disconnect = start + self.faults.disconnect_s if self.faults.disconnect_s else float("inf")
        try:
            while not stop.is_set() and (duration_s is None or time.monotonic() - start < duration_s):
                now = time.monotonic()
                if port is None or now >= next_disconnect:
                    if port is not None:  # injected disconnect
                        port.close()
                        self.counts["disconnects"] += 1
                        self.on_event({"event": "disconnect", "for_s": self.faults.disconnect_for_s})
                        stop.wait(self.faults.disconnect_for_s)
                        next_disconnect = time.monotonic() + self.faults.disconnect_s
                    port = self._reopen(stop)
                    decoder = P.FrameDecoder()
                    self._answers.clear()
                    continue
                try:
                    self._flush_answers(port, now)
                    data = port.read(4096)
                except (serial.SerialException, OSError) as exc:
                    self.on_event({"event": "port_lost", "error": port_error(exc)})
                    port.close()
                    port = None
                    continue
                if not data:
                    stop.wait(0.002)
                    continue
                for item in decoder.feed(data):
                    self._handle(item)
        finally:
            if port is not None:
                port.close()
        return dict(self.counts)

    def _reopen(self, stop: threading.Event):
        while not stop.is_set():
            try:
                port = serial.Serial(self.port_name, self.baud, timeout=0, write_timeout=1.0)
                self.on_event({"event": "port_open", "port": self.port_name})
                return port
            except serial.SerialException:
                stop.wait(0.1)
        return None

    def _handle(self, item) -> None:
        if isinstance(item, P.Frame) and self.faults.drop and self.rng.random() < self.faults.drop:
            self.counts["dropped"] += 1
            self.on_event({"event": "fault", "fault": "drop", "seq": item.seq})
            return
        if isinstance(item, P.Frame) and self.faults.corrupt and self.rng.random() < self.faults.corrupt:
            body = bytearray(item.body)
            body[self.rng.randrange(len(body))] ^= 1 << self.rng.randrange(8)
            self.counts["corrupted"] += 1
            self.on_event({"event": "fault", "fault": "corrupt", "seq": item.seq})
            item = P.decode_frame(P.cobs_encode(bytes(body)))
        self.counts["frames"] += 1
        if isinstance(item, P.DecodeError):
            self._reject(item.seq, P.nack_reason(item), item.reason)
            return
        try:
            msg = P.parse(item)
        except P.ProtocolError as exc:
            self._reject(item.seq, P.nack_reason(exc), str(exc))
            return
        event = {"event": "message", "seq": item.seq, **P.message_to_dict(msg), "t": time.time()}
        if isinstance(msg, P.Obstacles):
            self.counts["obstacles"] += 1
        if isinstance(msg, (P.Obstacles, P.Hello)):
            self._answer(P.Ack(item.seq))
            self.counts["acks"] += 1
        self.on_event(event)

    def _reject(self, seq: int, reason: int, detail: str) -> None:
        self.counts["errors"] += 1
        self.counts["nacks"] += 1
        self._answer(P.Nack(seq, reason))
        self.on_event({"event": "error", "reason": P.NACK_REASONS.get(reason, "unknown"), "seq": seq,
                       "detail": detail})

    def _answer(self, message) -> None:
        self._answers.append((time.monotonic() + self.faults.delay_s, P.encode(message, self._seq)))
        self._seq = (self._seq + 1) & 0xFFFF

    def _flush_answers(self, port, now: float) -> None:
        while self._answers and self._answers[0][0] <= now:
            port.write(self._answers.pop(0)[1])


def describe(event: dict) -> str | None:
    """One human line for an event (None for events not worth a line)."""
    kind = event["event"]
    if kind == "error":
        return f"NACK seq {event['seq']}: {event['reason']} ({event['detail']})"
    if kind in ("port_lost", "port_open", "disconnect", "fault"):
        return f"{kind}: " + ", ".join(f"{k}={v}" for k, v in event.items() if k != "event")
    if event["type"] == "OBSTACLES":
        segs = event["segments"]
        line = (f"OBSTACLES seq {event['seq']} frame {event['frame_seq']} stamp {event['stamp_ns']} ns: "
                f"{len(segs)}/{event['total']} segments{' TRUNCATED' if event['truncated'] else ''}")
        if segs:
            s = segs[0]
            p0 = ", ".join(f"{v:.1f}" for v in s["p0_mm"])
            p1 = ", ".join(f"{v:.1f}" for v in s["p1_mm"])
            line += (f"; nearest: branch {s['branch_id']} ({p0})-({p1}) mm r {s['radius_mm']:.2f} "
                     f"clear {s['clearance_mm']:.2f} mm")
        return line
    if event["type"] == "HEARTBEAT":
        return (f"HEARTBEAT camera {'ok' if event['camera_ok'] else 'LOST'}, "
                f"{'calibrated' if event['calibrated'] else 'NOT calibrated'}, {event['rate_hz']:.2f} Hz, "
                f"{event['results_dropped']} dropped")
    if event["type"] == "HELLO":
        return (f"HELLO protocol {event['protocol_version']}, {event['lsb_um']} um per unit, "
                f"appliance {event['app_version']}")
    return None
