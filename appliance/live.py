"""LiveServer: the topics of the field log, streamed to Foxglove over a WebSocket while running.

An engineer opens Foxglove -> Open connection -> Foxglove WebSocket -> ``ws://127.0.0.1:8765``
and sees the images, the branches in 3D and the diagnostics of the running appliance. The
topics, schemas and message contents are the log's (built by :mod:`appliance.logs.messages`
and :mod:`appliance.logs.images`), so a Foxglove layout made for logs works live too.

The server is `foxglove-sdk <https://pypi.org/project/foxglove-sdk/>`_ (optional extra
``live``): Foxglove's own implementation, a Rust server on its own threads that sends to each
client from a bounded queue, dropping that client's oldest messages when it falls behind.

Never blocks the caller: the write methods only hand their arguments to one worker thread
(a frame waiting there is replaced by a newer one; results and diagnostics wait in a short
queue whose oldest entry goes when it is full) and return. The worker builds and compresses
only what a client subscribed to: without a client the server costs next to nothing. Errors
never reach the caller: they are counted (``errors``) and logged once on the
``appliance.live`` logger.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections import deque
from functools import partial

import numpy as np

from appliance.errors import ApplianceError
from appliance.logs import messages as m
from appliance.logs.images import EncodedFrame, encode_frame

log = logging.getLogger("appliance.live")

INSTALL_HINT = "pip install 'appliance[live]'"
FRAME_TOPICS = (m.LEFT_IMAGE, m.RIGHT_IMAGE, m.LEFT_CALIBRATION, m.RIGHT_CALIBRATION, m.TF_STATIC)


class LiveError(ApplianceError):
    """The live server cannot start (foxglove-sdk missing, address in use)."""


class LiveServer:
    """A Foxglove WebSocket server streaming the log's topics; the writer methods of LogWriter.

    Parameters
    ----------
    host : str
        Address to listen on; loopback by default (the box is not exposed on the robot's network).
    port : int
        TCP port; 0 picks a free one (see ``port``).
    calibration : StereoCalibration, optional
        Sent as both cameras' CameraCalibration and ``/tf_static`` (right camera in the left)
        with a frame at most every ``calibration_period_s``, so a client that joins late gets them.
    image_encoding : {"jpeg", "png"}
        How frames given as StereoFrame are compressed (an EncodedFrame is sent as it is).
    jpeg_quality : int
        1-100.
    backlog_messages : int
        Messages queued per client in the server; when a client is behind, its oldest go first.
    queue_messages : int
        Results and diagnostics waiting for the worker; when full the oldest is dropped.
    calibration_period_s : float
    name : str
        Server name shown by Foxglove.

    Raises
    ------
    LiveError
        foxglove-sdk is not installed, or the address cannot be bound.

    Attributes
    ----------
    frames_sent, frames_dropped, results_sent, results_dropped, diagnostics_sent,
    diagnostics_dropped, errors : int
        Messages handed to the server (for at least one subscribed topic); messages dropped
        because the worker was behind, the server was closed or building them failed; errors
        while building or sending. A message nobody subscribed to is neither sent nor dropped.

    Notes
    -----
    Thread-safe: the write methods may be called from any thread.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 8765, *, calibration=None,
                 image_encoding: str = "jpeg", jpeg_quality: int = 90, backlog_messages: int = 32,
                 queue_messages: int = 16, calibration_period_s: float = 1.0, name: str = "appliance"):
        try:
            import foxglove
        except ImportError:
            raise LiveError(f"the live view needs foxglove-sdk: {INSTALL_HINT}") from None
        from mcap_protobuf.schema import build_file_descriptor_set

        self.calibration = calibration
        self.image_encoding, self.jpeg_quality = image_encoding, jpeg_quality
        self.calibration_period_s = calibration_period_s
        self.frames_sent = self.frames_dropped = 0
        self.results_sent = self.results_dropped = 0
        self.diagnostics_sent = self.diagnostics_dropped = 0
        self.errors = 0
        self._warned: set[str] = set()
        self._last_calibration_s = -np.inf
        self._context = foxglove.Context()     # this server's channels only: no global state
        try:
            self._server = foxglove.start_server(name=name, host=host, port=port, context=self._context,
                                                 message_backlog_size=backlog_messages)
        except Exception as exc:  # noqa: BLE001 - the SDK raises RuntimeError("FoxgloveError: ...")
            raise LiveError(f"{host}:{port}: cannot start the live server ({exc})") from None
        self.host, self.port = host, self._server.port
        self._channels = {}
        for topic, cls in m.PROTOBUF_TOPICS.items():
            schema = foxglove.Schema(name=cls.DESCRIPTOR.full_name, encoding="protobuf",
                                     data=build_file_descriptor_set(cls).SerializeToString())
            self._channels[topic] = foxglove.Channel(topic, schema=schema, message_encoding="protobuf",
                                                     context=self._context)
        for topic, body in m.JSON_TOPICS.items():
            schema = foxglove.Schema(name=body["title"], encoding="jsonschema", data=json.dumps(body).encode())
            self._channels[topic] = foxglove.Channel(topic, schema=schema, message_encoding="json",
                                                     context=self._context)
        self._cond = threading.Condition()
        self._frame = None                                  # newest frame waiting for the worker
        self._queue: deque = deque()                        # (kind, build, args) of results, diagnostics
        self._queue_max = queue_messages
        self._closing = False
        self._thread = threading.Thread(target=self._work, name="live", daemon=True)
        self._thread.start()

    # -- public -------------------------------------------------------------------------
    @property
    def url(self) -> str:
        """The address to open in Foxglove."""
        return f"ws://{self.host}:{self.port}"

    def stats(self) -> dict:
        """Counters for status lines and diagnostics."""
        return {"url": self.url, "frames_sent": self.frames_sent, "frames_dropped": self.frames_dropped,
                "results_sent": self.results_sent, "results_dropped": self.results_dropped,
                "diagnostics_sent": self.diagnostics_sent, "diagnostics_dropped": self.diagnostics_dropped,
                "errors": self.errors}

    def subscribed_topics(self) -> list[str]:
        """The topics at least one client subscribed to now."""
        return sorted(t for t, channel in self._channels.items() if channel.has_sinks())

    def write_frame(self, frame) -> bool:
        """Stream both images of a pair (a StereoFrame, or an EncodedFrame compressed elsewhere).

        Returns at once; compression happens in the worker, only when a client subscribed to
        an image or calibration topic. Returns False when the pair is not sent (no subscriber,
        server closed); a pair replaced by a newer one before the worker took it counts as dropped.
        """
        if not any(self._channels[t].has_sinks() for t in FRAME_TOPICS):
            return False
        with self._cond:
            if self._closing:
                self.frames_dropped += 1
                return False
            if self._frame is not None:
                self.frames_dropped += 1
            self._frame = frame
            self._cond.notify()
        return True

    def write_result(self, result, seq: int, camera_to_base=None) -> bool:
        """Stream a LocalizationResult: its JSON, its branches as cylinders, and ``/tf``.

        Parameters
        ----------
        result : LocalizationResult
        seq : int
            The frame's seq.
        camera_to_base : array_like, shape (4, 4), optional
            Camera frame -> arm base, mm. None: no ``/tf`` message.
        """
        return self._put("results", self._send_result, (result, seq, camera_to_base),
                         (m.RESULT, m.BRANCHES, m.TF))

    def write_diagnostics(self, diagnostics: dict, stamp_ns: int | None = None) -> bool:
        """Stream a JSON mapping on ``/diagnostics``, with this server's counters under ``live``."""
        return self._put("diagnostics", self._send_diagnostics, (dict(diagnostics), stamp_ns), (m.DIAGNOSTICS,))

    def close(self) -> None:
        """Send what is queued (up to 2 s), stop the server and close its channels. Safe to call twice."""
        with self._cond:
            if self._closing:
                return
            self._closing = True
            self._cond.notify()
        self._thread.join(timeout=2.0)
        try:
            self._server.stop()
            for channel in self._channels.values():
                channel.close()
        except Exception as exc:  # noqa: BLE001 - closing never raises
            self._error("close", exc)

    def __enter__(self) -> LiveServer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- worker -------------------------------------------------------------------------
    def _put(self, kind: str, build, args: tuple, topics: tuple) -> bool:
        if not any(self._channels[t].has_sinks() for t in topics):
            return False
        with self._cond:
            if self._closing:
                self._count(kind, False)
                return False
            if len(self._queue) >= self._queue_max:
                self._count(self._queue.popleft()[0], False)
            self._queue.append((kind, build, args))
            self._cond.notify()
        return True

    def _work(self) -> None:
        while True:
            with self._cond:
                while self._frame is None and not self._queue and not self._closing:
                    self._cond.wait()
                frame, self._frame = self._frame, None
                items = list(self._queue)
                self._queue.clear()
                if frame is None and not items:
                    return                                  # closing, nothing left
            if frame is not None:
                self._run("frames", self._send_frame, (frame,))
            for kind, build, args in items:
                self._run(kind, build, args)

    def _run(self, kind: str, send, args: tuple) -> None:
        try:
            ok = send(*args)
        except Exception as exc:  # noqa: BLE001 - never raise into the run loop
            self._error(send.__name__, exc)
            ok = False
        if ok is not None:                                  # None: nobody subscribed any more
            with self._cond:
                self._count(kind, ok)

    def _log(self, topic: str, message, stamp_ns: int) -> bool:
        """Send ``message`` (bytes, a protobuf message, or a function building one) on ``topic``
        if a client subscribed to it."""
        channel = self._channels[topic]
        if not channel.has_sinks():
            return False
        data = message() if callable(message) else message
        channel.log(data if isinstance(data, bytes) else data.SerializeToString(), log_time=int(stamp_ns))
        return True

    def _send_frame(self, frame) -> bool | None:
        images = [t for t in (m.LEFT_IMAGE, m.RIGHT_IMAGE) if self._channels[t].has_sinks()]
        enc = frame
        if images and not isinstance(frame, EncodedFrame):
            enc = encode_frame(frame, self.image_encoding, self.jpeg_quality)
        stamp = int(enc.stamp_left_ns)
        sent = False
        now_s = time.monotonic()
        if self.calibration is not None and now_s - self._last_calibration_s >= self.calibration_period_s:
            self._last_calibration_s = now_s
            left, right = m.calibration_messages(self.calibration, stamp)
            sent |= self._log(m.LEFT_CALIBRATION, left, stamp)
            sent |= self._log(m.RIGHT_CALIBRATION, right, stamp)
            sent |= self._log(m.TF_STATIC, partial(m.right_camera_message, self.calibration, stamp), stamp)
        for topic, side, frame_id in ((m.LEFT_IMAGE, "left", m.CAMERA_FRAME), (m.RIGHT_IMAGE, "right", m.RIGHT_FRAME)):
            if topic in images:
                image_stamp = int(getattr(enc, f"stamp_{side}_ns"))
                build = partial(m.image_message, getattr(enc, side), enc.format, image_stamp, frame_id)
                sent |= self._log(topic, build, image_stamp)
        return sent or None

    def _send_result(self, result, seq: int, camera_to_base) -> bool | None:
        stamp = int(result.stamp_ns) or time.time_ns()
        sent = self._log(m.RESULT, partial(m.result_json, result, seq), stamp)
        sent |= self._log(m.BRANCHES, partial(m.branches_message, result, stamp), stamp)
        if camera_to_base is not None:
            pose = np.asarray(camera_to_base, np.float64)
            sent |= self._log(m.TF, partial(m.camera_to_base_message, pose, stamp), stamp)
        return sent or None

    def _send_diagnostics(self, diagnostics: dict, stamp_ns: int | None) -> bool | None:
        stamp = int(stamp_ns) if stamp_ns else time.time_ns()
        return self._log(m.DIAGNOSTICS, lambda: m.to_json({"stamp_ns": stamp, **diagnostics, "live": self.stats()}),
                         stamp) or None

    # -- counting -----------------------------------------------------------------------
    def _count(self, kind: str, ok: bool) -> None:
        name = f"{kind}_{'sent' if ok else 'dropped'}"
        setattr(self, name, getattr(self, name) + 1)

    def _error(self, key: str, exc: Exception) -> None:
        with self._cond:
            self.errors += 1
        if key not in self._warned:
            self._warned.add(key)
            log.warning("live view: message not sent (%s: %s)", type(exc).__name__, exc)
