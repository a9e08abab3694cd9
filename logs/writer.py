"""LogWriter: writes a field log (MCAP) that survives kill -9, rotation and a full disk.

Crash safety: messages go into MCAP chunks of ``logging.chunk_size_bytes``; a chunk is also
closed and handed to the OS at least every ``logging.flush_interval_s``. A process killed at any
moment therefore leaves a file whose every complete chunk is readable (``appliance logs
recover``): at most about one flush interval of data is lost.

A disk with less than ``logging.min_free_bytes`` free (checked at each flush), or any write
error (ENOSPC, EIO, ...) stops logging with one message on the ``appliance.logs`` logger; the
file is finished if it can be. From then on the write methods return False and count what
they drop: they never raise into the caller once the writer is open.

Thread-safe: writes are serialised by a lock; a StereoFrame is compressed before taking it, so
threads can compress while another writes (or call :func:`~appliance.logs.images.encode_frame`
anywhere and pass the EncodedFrame).
"""

from __future__ import annotations

import errno
import json
import logging
import os
import shutil
import threading
import time
from datetime import datetime, timezone
from pathlib import Path

import mcap
import numpy as np
from mcap.writer import CompressionType, Writer
from mcap_protobuf.schema import build_file_descriptor_set

from appliance.logs import messages as m
from appliance.logs.errors import LogError
from appliance.logs.images import EncodedFrame, encode_frame
from appliance.logs.metadata import calibration_record, config_record, device_record, version_record

log = logging.getLogger("appliance.logs")

NO_SPACE = (errno.ENOSPC, errno.EDQUOT)
RECORD_OVERHEAD_BYTES = 48  # a message record's header plus its index entry, for the size estimate


class LogWriter:
    """Write raw frames, results, transforms and diagnostics of a run to MCAP files.

    Parameters
    ----------
    folder : str or Path
        Folder for the files (created), named ``<prefix>_<UTC start>_<NNN>.mcap``; or a path
        ending in ``.mcap``: the first file is exactly that, later ones ``<stem>_<NNN>.mcap``.
    cfg : LoggingConfig
        ``image_encoding``, ``jpeg_quality``, ``chunk_size_bytes``, ``flush_interval_s``,
        ``rotate_size_bytes``, ``rotate_duration_s``, ``min_free_bytes``.
    calibration : StereoCalibration, optional
        Written as metadata and as both cameras' CameraCalibration in every file.
    config_dict : dict, optional
        The effective configuration (metadata ``config``).
    device : str or DriverInfo, optional
        Metadata ``device``.
    version : str, optional
        Software version (metadata ``version``).

    Raises
    ------
    LogError
        The folder or the first file cannot be created (e.g. permission denied). A full or
        nearly full disk does not raise: logging is stopped at once (see ``stop_reason``).

    Attributes
    ----------
    paths : list of Path
        Every file started, in order; ``path`` is the current (last) one.
    frames_written, frames_dropped, results_written, results_dropped, diagnostics_written,
    diagnostics_dropped : int
        Messages handed to the file, and messages dropped (logging stopped, bad input). When a
        write fails (disk full) the chunk in progress is lost too: at most ``chunk_size_bytes``
        or ``flush_interval_s`` of messages counted as written.
    stop_reason : str or None
        Why logging stopped early (low disk, write error), else None.
    """

    def __init__(self, folder, cfg, *, calibration=None, config_dict=None, device="", version=None,
                 prefix: str = "appliance"):
        self.cfg = cfg
        folder = Path(folder)
        start = datetime.now(timezone.utc).strftime("%Y%m%d-%H%M%S")
        if folder.suffix.lower() == ".mcap":
            self.folder, self._stem, self._first_name = folder.parent, folder.stem, folder.name
        else:
            self.folder, self._stem, self._first_name = folder, f"{prefix}_{start}", None
        self.calibration = calibration
        self._records = {"config": config_record(config_dict), "version": version_record(version),
                         "device": device_record(device)}
        if calibration is not None:
            self._records["calibration"] = calibration_record(calibration)
        self._library = f"appliance {version or '?'} (mcap {getattr(mcap, '__version__', '?')})"
        self.paths: list[Path] = []
        self.frames_written = self.frames_dropped = 0
        self.results_written = self.results_dropped = 0
        self.diagnostics_written = self.diagnostics_dropped = 0
        self.stop_reason: str | None = None
        self._writer = self._file = None
        self._counter = 0
        self._warned: set[str] = set()
        self._lock = threading.RLock()
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise LogError(f"{self.folder}: cannot create the log folder ({exc.strerror})") from None
        if not os.access(self.folder, os.W_OK):
            raise LogError(f"{self.folder}: log folder is not writable")
        self._open_next()

    # -- public -------------------------------------------------------------------------
    @property
    def path(self) -> Path | None:
        """The file being written (the last one once stopped or closed)."""
        return self.paths[-1] if self.paths else None

    @property
    def stopped(self) -> bool:
        """True once logging stopped early; the write methods then only count drops."""
        return self.stop_reason is not None

    def stats(self) -> dict:
        """Counters for status lines and diagnostics."""
        return {"files": len(self.paths), "frames_written": self.frames_written,
                "frames_dropped": self.frames_dropped, "results_written": self.results_written,
                "results_dropped": self.results_dropped, "diagnostics_written": self.diagnostics_written,
                "diagnostics_dropped": self.diagnostics_dropped, "stopped": self.stop_reason}

    def write_frame(self, frame) -> bool:
        """Log both images of a pair (a StereoFrame, or an EncodedFrame compressed elsewhere).

        Returns
        -------
        bool
            False when the pair was dropped (logging stopped, or the images cannot be encoded).
        """
        enc = frame
        if not isinstance(frame, EncodedFrame) and self._writer is not None:
            try:  # outside the lock: another thread may write meanwhile
                enc = encode_frame(frame, self.cfg.image_encoding, self.cfg.jpeg_quality)
            except Exception as exc:  # noqa: BLE001 - a bad frame is dropped, never raised
                self._warn_once("frame", f"logging: frame {getattr(frame, 'seq', '?')} not logged: {exc}")
                enc = None
        return self._guarded("frames", self._write_frame, enc)

    def write_result(self, result, seq: int, camera_to_base=None) -> bool:
        """Log a LocalizationResult: its JSON, its branches as cylinders, and ``/tf``.

        Parameters
        ----------
        result : LocalizationResult
        seq : int
            The frame's seq.
        camera_to_base : array_like, shape (4, 4), optional
            Camera frame -> arm base, mm. None: no ``/tf`` message.
        """
        return self._guarded("results", self._write_result, result, seq, camera_to_base)

    def write_diagnostics(self, diagnostics: dict, stamp_ns: int | None = None) -> bool:
        """Log a JSON mapping on ``/diagnostics`` (rates Hz, latencies ms, drops, temperatures)."""
        return self._guarded("diagnostics", self._write_diagnostics, diagnostics, stamp_ns)

    def flush(self) -> bool:
        """Hand everything logged so far to the OS now (e.g. when the camera is lost: the
        interval flush only happens on writes). Returns False when logging has stopped."""
        return self._guarded(None, self._flush)

    def close(self) -> None:
        """Finish the current file with its index. Safe to call twice; never raises."""
        with self._lock:
            self._finish()

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- files --------------------------------------------------------------------------
    def _next_path(self) -> Path:
        if self._first_name and not self.paths:
            return self.folder / self._first_name
        while True:
            path = self.folder / f"{self._stem}_{self._counter:03d}.mcap"
            self._counter += 1
            if not path.exists():
                return path

    def _open_next(self) -> None:
        """Start a file: header, schemas and channels of every topic, metadata records."""
        if self._low_disk():
            return
        path, first = self._next_path(), not self.paths
        try:
            self._file = open(path, "wb")
            self.paths.append(path)
            w = Writer(self._file, chunk_size=self.cfg.chunk_size_bytes, compression=CompressionType.NONE)
            w.start(profile="", library=self._library)
            self._channels = {}
            for topic, cls in m.PROTOBUF_TOPICS.items():
                sid = w.register_schema(cls.DESCRIPTOR.full_name, "protobuf",
                                        build_file_descriptor_set(cls).SerializeToString())
                self._channels[topic] = w.register_channel(topic, "protobuf", sid)
            for topic, schema in m.JSON_TOPICS.items():
                sid = w.register_schema(schema["title"], "jsonschema", json.dumps(schema).encode())
                self._channels[topic] = w.register_channel(topic, "json", sid)
            for name, record in self._records.items():
                w.add_metadata(name, record)
            self._file.flush()
        except OSError as exc:
            _close_quietly(self._file)
            self._writer = self._file = None
            if exc.errno in NO_SPACE or not first:
                self._stop(f"{path}: {exc.strerror}")
                return
            raise LogError(f"{path}: cannot create the log file ({exc.strerror})") from None
        self._writer = w
        self._file_first_ns = None
        self._file_bytes = self._file.tell()  # + messages still in the chunk being built
        self._last_flush = time.monotonic()

    def _finish(self) -> None:
        w, f = self._writer, self._file
        self._writer = self._file = None
        if f is None:
            return
        try:
            if w is not None:
                w.finish()
            f.flush()
            os.fsync(f.fileno())
        except Exception as exc:  # noqa: BLE001 - the file stays recoverable
            self._stop(f"{self.path}: could not finish the file ({exc}); `appliance logs recover` reads it")
        finally:
            _close_quietly(f)

    def _rotate_due(self, stamp_ns: int) -> bool:
        size, duration = self.cfg.rotate_size_bytes, self.cfg.rotate_duration_s
        if size and max(self._file.tell(), self._file_bytes) >= size:
            return True
        return bool(duration and self._file_first_ns is not None
                    and stamp_ns - self._file_first_ns >= duration * 1e9)

    # -- writing ------------------------------------------------------------------------
    def _guarded(self, kind: str | None, write, *args) -> bool:
        """Run a write under the lock and count it as ``<kind>_written`` or ``<kind>_dropped``.

        An OS error stops logging; anything else drops this message only. None in ``args``
        (a frame that could not be encoded) is a drop.
        """
        with self._lock:
            ok = self._writer is not None and not (args and args[0] is None)
            if ok:
                try:
                    write(*args)
                    if self._writer is not None and time.monotonic() - self._last_flush >= self.cfg.flush_interval_s:
                        self._flush()
                except OSError as exc:
                    self._stop(f"{self.path}: write failed ({exc.strerror or exc})")
                    self._finish()
                    ok = False
                except Exception as exc:  # noqa: BLE001 - never raise into the run loop
                    self._warn_once(write.__name__, f"logging: message not logged ({type(exc).__name__}: {exc})")
                    ok = False
            if kind is not None:
                name = f"{kind}_{'written' if ok else 'dropped'}"
                setattr(self, name, getattr(self, name) + 1)
            return ok

    def _add(self, topic: str, data: bytes, log_time_ns: int, sequence: int = 0) -> None:
        self._file_bytes += len(data) + RECORD_OVERHEAD_BYTES
        self._writer.add_message(self._channels[topic], log_time=int(log_time_ns), data=data,
                                 publish_time=time.time_ns(), sequence=int(sequence) & 0xFFFFFFFF)

    def _write_frame(self, enc: EncodedFrame) -> None:
        if self._rotate_due(enc.stamp_left_ns):
            self._finish()
            self._open_next()
            if self._writer is None:
                raise OSError(errno.ENOSPC, self.stop_reason or "logging stopped")
        if self._file_first_ns is None:
            self._file_first_ns = enc.stamp_left_ns
            if self.calibration is not None:
                for topic, msg in zip((m.LEFT_CALIBRATION, m.RIGHT_CALIBRATION),
                                      m.calibration_messages(self.calibration, enc.stamp_left_ns)):
                    self._add(topic, msg.SerializeToString(), enc.stamp_left_ns)
                self._add(m.TF_STATIC, m.right_camera_message(self.calibration, enc.stamp_left_ns)
                          .SerializeToString(), enc.stamp_left_ns)
        for topic, data, stamp, frame_id in ((m.LEFT_IMAGE, enc.left, enc.stamp_left_ns, m.CAMERA_FRAME),
                                             (m.RIGHT_IMAGE, enc.right, enc.stamp_right_ns, m.RIGHT_FRAME)):
            msg = m.image_message(data, enc.format, stamp, frame_id)
            self._add(topic, msg.SerializeToString(), stamp, enc.seq)

    def _write_result(self, result, seq: int, camera_to_base) -> None:
        stamp = int(result.stamp_ns) or time.time_ns()
        self._add(m.RESULT, m.result_json(result, seq), stamp, seq)
        self._add(m.BRANCHES, m.branches_message(result, stamp).SerializeToString(), stamp, seq)
        if camera_to_base is not None:
            tf = m.camera_to_base_message(np.asarray(camera_to_base, np.float64), stamp)
            self._add(m.TF, tf.SerializeToString(), stamp, seq)

    def _write_diagnostics(self, diagnostics: dict, stamp_ns: int | None) -> None:
        stamp = int(stamp_ns) if stamp_ns else time.time_ns()
        body = {"stamp_ns": stamp, **diagnostics, "log_writer": self.stats()}
        self._add(m.DIAGNOSTICS, m.to_json(body), stamp)

    def _flush(self) -> None:
        """Close the chunk in progress and hand it to the OS; then check the free space."""
        self._writer.flush()
        self._last_flush = time.monotonic()
        if self._low_disk():
            self._finish()

    # -- stopping -----------------------------------------------------------------------
    def _low_disk(self) -> bool:
        """Stop (once) when the log folder's disk has less than ``min_free_bytes`` free."""
        free = shutil.disk_usage(self.folder).free
        if free >= self.cfg.min_free_bytes:
            return False
        self._stop(f"{self.folder}: {free / 1e6:.0f} MB free, below logging.min_free_bytes "
                   f"({self.cfg.min_free_bytes / 1e6:.0f} MB)")
        return True

    def _stop(self, reason: str) -> None:
        if self.stop_reason is None:
            self.stop_reason = reason
            log.error("logging stopped: %s; localization goes on, nothing more is logged", reason)

    def _warn_once(self, key: str, message: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            log.warning(message)


def _close_quietly(f) -> None:
    """Close a file whose buffered bytes may no longer fit on the disk."""
    if f is not None:
        try:
            f.close()
        except OSError:
            pass
