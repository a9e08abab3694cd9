"""The sender side of the arm-controller serial link: never blocks the caller, survives unplugging.

Usage (the run loop)::

    link = ArmLink(cfg.serial, cfg.arm.camera_to_base)
    link.open()                      # ArmLinkError: port missing (unless serial.wait_for_port)
    link.set_status(camera_ok=True, calibrated=True, rate_hz=29.8)   # goes out in HEARTBEAT
    link.submit(result, seq)         # returns at once; the newest results win
    link.stats()                     # {"sent": ..., "dropped": ..., "connected": ..., ...}
    link.close()                     # sends what is queued (at most ``drain_s``), then closes

or ``with ArmLink(...) as link:``. One worker thread owns the port:

- ``submit`` appends to a queue of ``serial.queue_results``; when it is full the oldest
  result is dropped and counted (``dropped``). The worker converts each result into an
  OBSTACLES message (:func:`appliance.arm.protocol.obstacles_from_result`: camera ->
  arm-base transform, nearest segments first, truncated to what ``serial.baud`` carries
  in one period of ``serial.frame_rate_hz``).
- Writes give up after ``serial.write_timeout_s`` (``write_timeouts``); the next frame
  is then preceded by a 0x00 so the receiver drops the partial one.
- ``serial.ack_mode``: after each OBSTACLES the worker waits ``serial.ack_timeout_s`` for
  the ACK of its sequence number; on NACK or time-out it retransmits the latest obstacle
  set (a newer queued result replaces it instead: ``superseded``) at most
  ``serial.max_retries`` times (then ``gave_up``).
- HEARTBEAT every ``serial.heartbeat_s`` with the status of :meth:`ArmLink.set_status`.
- A port that vanishes (USB unplugged, read/write error) is closed and reopened with
  back-off from ``serial.reconnect_min_s`` doubling to ``serial.reconnect_max_s``;
  results submitted meanwhile are dropped by the queue as usual. Every (re)connection
  starts with 0x00 and a HELLO. The caller never sees an exception after ``open``.
"""

from __future__ import annotations

import os
import threading
import time
from collections import deque

import numpy as np
import serial

from appliance import software_version
from appliance.arm import protocol as P
from appliance.errors import ApplianceError

COUNTERS = ("submitted", "dropped", "sent", "bytes_sent", "truncated", "heartbeats", "acked", "nacked",
            "retransmits", "superseded", "gave_up", "write_timeouts", "rx_errors", "connects",
            "disconnects", "errors")


class ArmLinkError(ApplianceError):
    """The arm-controller port cannot be used (named in the message)."""


class ArmLink:
    """Sends localization results to the arm controller (see the module docstring).

    Parameters
    ----------
    cfg : appliance.config.schema.SerialConfig
        ``port``, ``baud``, time-outs, ACK mode, back-off, queue length, frame rate.
    camera_to_base : array_like (4, 4)
        p_base = camera_to_base @ [X, Y, Z, 1], mm.
    """

    def __init__(self, cfg, camera_to_base):
        if cfg.port is None:
            raise ArmLinkError("serial.port: no arm-controller port configured")
        self.cfg = cfg
        self.camera_to_base = np.asarray(camera_to_base, float).reshape(4, 4)
        self.max_bytes = P.budget_bytes(cfg.baud, cfg.frame_rate_hz)
        self._queue: deque = deque()
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._port: serial.Serial | None = None
        self._counts = dict.fromkeys(COUNTERS, 0)
        self._status = P.Heartbeat(0, False, False, 0.0, cfg.ack_mode)
        self._last_error = ""
        self._seq = 0
        self._decoder = P.FrameDecoder()
        self._pending = None  # ACK mode: [seq, wire bytes, sent at (monotonic s), retries]
        self._resync = True  # precede the next frame with 0x00

    # -- caller side -----------------------------------------------------------------------
    def open(self) -> ArmLink:
        """Open the port and start the worker; ArmLinkError if the port is missing (unless waiting)."""
        try:
            self._connect()
        except serial.SerialException as exc:
            if not self.cfg.wait_for_port:
                raise ArmLinkError(f"serial port {self.cfg.port}: cannot open ({port_error(exc)}); "
                                   "set serial.wait_for_port: true to wait for it") from None
            self._last_error = port_error(exc)
        self._thread = threading.Thread(target=self._run, name="arm-link", daemon=True)
        self._thread.start()
        return self

    def submit(self, result, seq: int) -> None:
        """Queue ``result`` (a LocalizationResult) of frame ``seq`` for sending; never blocks."""
        with self._lock:
            self._counts["submitted"] += 1
            if len(self._queue) >= self.cfg.queue_results:
                self._queue.popleft()
                self._counts["dropped"] += 1
            self._queue.append((result, int(seq)))
        self._wake.set()

    def set_status(self, camera_ok: bool, calibrated: bool, rate_hz: float) -> None:
        """Status flags and result rate (Hz) sent in the next HEARTBEATs."""
        with self._lock:
            self._status = P.Heartbeat(0, bool(camera_ok), bool(calibrated), float(rate_hz),
                                       self.cfg.ack_mode)

    def stats(self) -> dict:
        """Counters since ``open`` plus ``connected``, ``queued``, ``last_error``, ``max_segments``.

        Counters: ``submitted``, ``dropped`` (pushed out of the queue by newer results),
        ``sent`` (OBSTACLES written), ``bytes_sent``, ``truncated``, ``heartbeats``, ``acked``,
        ``nacked``, ``retransmits``, ``superseded`` (unacknowledged set replaced by a newer
        one), ``gave_up`` (retries exhausted), ``write_timeouts``, ``rx_errors`` (bad frames
        from the controller), ``connects``, ``disconnects``, ``errors`` (anything else that
        went wrong, e.g. a result that cannot be encoded; ``last_error`` says what).
        """
        with self._lock:
            out = dict(self._counts)
            out["queued"] = len(self._queue)
        out["connected"] = self._port is not None
        out["last_error"] = self._last_error
        out["max_segments"] = P.max_segments(self.max_bytes)
        return out

    def close(self, drain_s: float = 1.0) -> None:
        """Send what is queued (waiting at most ``drain_s``), stop the worker, close the port."""
        deadline = time.monotonic() + drain_s
        while self._thread is not None and time.monotonic() < deadline and self._port is not None:
            with self._lock:
                if not self._queue and self._pending is None:
                    break
            time.sleep(0.005)
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=self.cfg.write_timeout_s + 2.0)
            self._thread = None
        self._disconnect(count=False)

    def __enter__(self) -> ArmLink:
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

    # -- worker ----------------------------------------------------------------------------
    def _run(self) -> None:
        backoff = self.cfg.reconnect_min_s
        next_heartbeat = time.monotonic()
        while not self._stop.is_set():
            if self._port is None:
                try:
                    self._connect()
                    backoff = self.cfg.reconnect_min_s
                except serial.SerialException as exc:
                    self._last_error = port_error(exc)
                    self._stop.wait(backoff)
                    backoff = min(2 * backoff, self.cfg.reconnect_max_s)
                    continue
            try:
                self._receive()
                now = time.monotonic()
                if now >= next_heartbeat:
                    with self._lock:
                        hb = self._status
                        dropped = self._counts["dropped"]
                    self._send(P.Heartbeat(time.time_ns(), hb.camera_ok, hb.calibrated, hb.rate_hz,
                                           hb.ack_mode, dropped))
                    self._counts["heartbeats"] += 1
                    next_heartbeat = now + self.cfg.heartbeat_s
                if self.cfg.ack_mode and self._pending is not None:
                    self._check_ack(now)
                if self._pending is None:
                    self._send_next()
                wait = 0.002 if self._pending is not None else max(0.0, min(0.02, next_heartbeat - now))
                self._wake.wait(wait)
                self._wake.clear()
            except serial.SerialTimeoutException:
                self._counts["write_timeouts"] += 1
                self._resync = True
            except (serial.SerialException, OSError) as exc:
                self._last_error = port_error(exc)
                self._disconnect()
            except Exception as exc:  # noqa: BLE001 - the link must outlive any one bad result
                self._counts["errors"] += 1
                self._last_error = f"{type(exc).__name__}: {exc}"
                self._stop.wait(0.01)

    def _send_next(self) -> None:
        with self._lock:
            if not self._queue:
                return
            result, frame_seq = self._queue.popleft()
        obstacles = P.obstacles_from_result(result, self.camera_to_base, self.max_bytes, frame_seq=frame_seq,
                                            tolerance_mm=self.cfg.segment_tolerance_mm)
        seq, wire = self._send(obstacles)
        self._counts["sent"] += 1
        self._counts["truncated"] += obstacles.truncated
        if self.cfg.ack_mode:
            self._pending = [seq, wire, time.monotonic(), 0]

    def _check_ack(self, now: float) -> None:
        seq, wire, sent_at, retries = self._pending
        if sent_at is not None and now - sent_at < self.cfg.ack_timeout_s:  # sent_at None: NACKed
            return
        with self._lock:
            newer = bool(self._queue)
        if newer:
            self._counts["superseded"] += 1
            self._pending = None
        elif retries >= self.cfg.max_retries:
            self._counts["gave_up"] += 1
            self._pending = None
        else:
            self._write(wire)
            self._counts["retransmits"] += 1
            self._pending = [seq, wire, time.monotonic(), retries + 1]

    def _receive(self) -> None:
        data = self._port.read(4096)
        if not data:
            return
        for item in self._decoder.feed(data):
            if isinstance(item, P.DecodeError):
                self._counts["rx_errors"] += 1
                continue
            try:
                msg = P.parse(item)
            except P.ProtocolError:
                self._counts["rx_errors"] += 1
                continue
            pending = self._pending
            if isinstance(msg, P.Ack) and pending is not None and msg.seq == pending[0]:
                self._counts["acked"] += 1
                self._pending = None
            elif isinstance(msg, P.Nack):
                self._counts["nacked"] += 1
                if pending is not None and msg.seq in (pending[0], P.SEQ_UNKNOWN):
                    pending[2] = None  # retransmit (or supersede) at once

    def _send(self, message) -> tuple[int, bytes]:
        seq = self._seq
        self._seq = (self._seq + 1) & 0xFFFF
        wire = P.encode(message, seq)
        self._write(wire)
        return seq, wire

    def _write(self, wire: bytes) -> None:
        if self._resync:
            wire = b"\0" + wire
        self._port.write(wire)
        self._resync = False
        self._counts["bytes_sent"] += len(wire)

    def _connect(self) -> None:
        port = serial.Serial(self.cfg.port, self.cfg.baud, timeout=0, write_timeout=self.cfg.write_timeout_s)
        self._port = port
        self._decoder = P.FrameDecoder()
        self._pending = None
        self._resync = True
        self._counts["connects"] += 1
        try:
            self._send(P.Hello(software_version()))
        except serial.SerialTimeoutException:
            self._counts["write_timeouts"] += 1
            self._resync = True
        except (serial.SerialException, OSError) as exc:
            self._disconnect()
            raise serial.SerialException(port_error(exc)) from None

    def _disconnect(self, count: bool = True) -> None:
        port, self._port = self._port, None
        if port is not None:
            self._counts["disconnects"] += count
            try:
                port.close()
            except (serial.SerialException, OSError):
                pass


def port_error(exc: Exception) -> str:
    """A pyserial error as a short phrase ("No such file or directory"), one line."""
    if getattr(exc, "errno", None):
        return os.strerror(exc.errno)
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
