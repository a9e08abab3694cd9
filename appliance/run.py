"""The run loop: acquire -> localize -> outputs (MCAP log, arm link), wired in one place.

Three threads and two bounded queues::

    acquire ──frames(2)──> localize ──> arm link (its own bounded queue, newest wins)
                                    ├──> live view (optional; its own worker, newest wins)
                                    └──log(logging.queue_frames)──> MCAP writer

- A camera is never stalled: when the localizer is busy the oldest waiting pair is dropped;
  when the writer is behind, the pair is not logged. Both are counted and written to
  ``/diagnostics``. A *replay* (``fake:`` at its recorded or nominal pace, or as fast as
  possible: ``camera.fake_rate_hz`` <= 0) is never dropped by the localizer queue: it
  localizes every recorded pair, so its results are reproducible. ``fake:`` at a fixed rate
  (``fake_rate_hz`` > 0) stands in for a camera and drops like one.
- Latency is capture stamp -> result for a camera, arrival in the loop -> result for a replay
  (whose stamps are the recording's).
- With ``opts.workers`` > 1 the pairs are localized in that many processes (the localizer is
  Python-heavy: threads would share one core); results still leave in capture order.
- A pair the localizer fails on (an exception) is counted (``failed_localize``), noted in the
  log's ``/diagnostics`` with its sequence number and stamp, logged as frames without a result
  (so the replay reproduces the failure) and skipped: nothing is sent to the arm for it, never
  an empty "no obstacles". ``MAX_FAILED_IN_ROW`` failures in a row stop the run with the error.
- A camera lost mid-run is reopened with back-off (``camera.reconnect_min_s`` doubling up
  to ``camera.reconnect_max_s``); the gap is counted and logged. A camera that cannot be
  opened at start is an error.
- ``stop`` (set by SIGINT/SIGTERM in the command) ends acquisition; what is queued is
  localized and written, and the log is finished with its index.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import queue
import threading
import time
from collections import deque
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from appliance import software_version
from appliance.acquire import AcquireError, StereoFrame, check_device, open_driver
from appliance.calibrate.model import StereoCalibration
from appliance.config import Config
from appliance.config.load import config_to_dict
from appliance.errors import ApplianceError
from appliance.localize import Localizer
from appliance.shared_frames import SharedFrames, SlotRef, attach, pair_view

_END = object()  # end-of-stream marker in the queues
MAX_FAILED_IN_ROW = 30  # pairs in a row the localizer fails on before the run stops (1 s at 30 Hz)
_WORKER: dict = {}  # in a localizer worker process only: its Localizer and the shared frames it reads


class LocalizeFailed(ApplianceError):
    """The localizer failed on too many pairs in a row for the run to go on."""


def _start_worker(calib: StereoCalibration, cfg, variant: str) -> None:
    """Initializer of a localizer worker process: build its Localizer once."""
    _WORKER["localizer"] = Localizer(calib, cfg, variant=variant)


def _localize_in_worker(pair: SlotRef | tuple[np.ndarray, np.ndarray], stamp_ns: int):
    """Localize one pair in a worker: read in place from shared memory (a SlotRef), or as sent."""
    if isinstance(pair, SlotRef):
        if pair.name not in _WORKER:
            _WORKER[pair.name] = attach(pair.name)
        pair = pair_view(_WORKER[pair.name].buf, pair.slot, pair.shape)
    return _WORKER["localizer"].localize(pair[0], pair[1], stamp_ns=stamp_ns)


def _finish(q: queue.Queue, timeout_s: float = 5.0) -> None:
    """Put the end marker; if the consumer is stuck, make room by dropping the oldest item."""
    try:
        q.put(_END, timeout=timeout_s)
    except queue.Full:
        try:
            q.get_nowait()
        except queue.Empty:
            pass
        q.put_nowait(_END)


@dataclass
class RunStatus:
    """A snapshot of the loop for the status line and ``/diagnostics``.

    Counts are since the start; rates and latencies over the last few seconds.
    """

    pairs: int = 0                  # pairs delivered by the camera
    localized: int = 0              # pairs localized
    dropped_localize: int = 0       # pairs the localizer had no time for
    dropped_log: int = 0            # pairs not logged because the writer was behind
    dropped_driver: int = 0         # pairs the driver dropped (stamp skew)
    failed_localize: int = 0        # pairs the localizer failed on (skipped; see /diagnostics)
    reconnects: int = 0             # times the camera was reopened
    camera_ok: bool = True
    rate_hz: float = 0.0            # localized pairs per second
    latency_p50_ms: float = 0.0     # capture -> result
    latency_p99_ms: float = 0.0
    features: int = 0               # in the latest result
    branches: int = 0
    arm: dict = field(default_factory=dict)   # the arm link's counters
    log_paths: list[str] = field(default_factory=list)
    live: dict = field(default_factory=dict)  # the live server's url and counters
    logging: bool = False           # the log is being written (false after low disk)

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["rate_hz"], d["latency_p50_ms"], d["latency_p99_ms"] = (
            round(v, 3) for v in (self.rate_hz, self.latency_p50_ms, self.latency_p99_ms))
        return d


@dataclass(frozen=True)
class RunOptions:
    """What ``appliance run`` was asked to do (the rest is in :class:`Config`)."""

    device: str
    log_dir: Path | None = None     # None: no MCAP log
    frames: int | None = None       # stop after this many pairs; None: until stopped / end of replay
    variant: str = "improved"       # localizer variant: improved | paper
    live_port: int | None = None    # Foxglove WebSocket server on 127.0.0.1:live_port; None: none
    workers: int = 1                # localizer processes; 1 = in the loop's own thread
    status_period_s: float = 0.5    # how often ``on_status`` is called and diagnostics written


def run_loop(cfg: Config, calib: StereoCalibration, opts: RunOptions, *,
             stop: threading.Event | None = None,
             on_status: Callable[[RunStatus], None] | None = None) -> RunStatus:
    """Run acquire -> localize -> outputs until ``stop``, ``opts.frames`` or the end of a replay.

    Parameters
    ----------
    cfg : Config
        The effective configuration; ``cfg.serial.port`` (not None) enables the arm link.
    calib : StereoCalibration
        The rig's calibration; its image size must match the camera's.
    opts : RunOptions
    stop : threading.Event, optional
        Set it (e.g. from a signal handler) to end the run cleanly.
    on_status : callable, optional
        Called from the calling thread with a :class:`RunStatus` every ``opts.status_period_s``.

    Returns
    -------
    RunStatus
        The final counters.

    Raises
    ------
    AcquireError
        The camera cannot be opened at start.
    ApplianceError
        The arm port is missing at start (and ``serial.wait_for_port`` is false), or the
        log folder cannot be written.
    """
    return _Loop(cfg, calib, opts, stop or threading.Event(), on_status).run()


class _Loop:
    def __init__(self, cfg, calib, opts, stop, on_status):
        self.cfg, self.calib, self.opts, self.stop, self.on_status = cfg, calib, opts, stop, on_status
        self.status = RunStatus()
        self.replay = opts.device.startswith("fake:") and cfg.camera.fake_rate_hz <= 0
        self.frames_q: queue.Queue = queue.Queue(maxsize=2)
        self.log_q: queue.Queue = queue.Queue(maxsize=cfg.logging.queue_frames)
        check_device(opts.device)     # a typo'd device fails now, not after the kernels load (seconds)
        # built here even with worker processes: a bad calibration or setting fails now, in one line
        # (its kernels are loaded only where it localizes)
        self.localizer = Localizer(calib, cfg.localize, variant=opts.variant, warm=opts.workers == 1)
        self.camera_to_base = np.asarray(cfg.arm.camera_to_base, float)
        self._done_ns: deque = deque(maxlen=120)      # result times, for the rate
        self._latency_ms: deque = deque(maxlen=300)
        self.error: BaseException | None = None
        self._failed_in_row = 0

    # -- wiring --------------------------------------------------------------------------
    def run(self) -> RunStatus:
        self.pool = self._start_pool()                  # before the camera: workers take a second to start
        try:
            driver = open_driver(self.opts.device, self.cfg.camera)   # errors at start are fatal
        except BaseException:
            self._stop_pool()
            raise
        self.writer = self.live = self.arm = None
        try:
            self._check_size(driver)
            self.writer = self._open_writer(driver)
            self.live = self._open_live()
            self.arm = self._open_arm()
        except BaseException:
            for part in (driver, self.writer, self.live):
                if part is not None:
                    part.close()
            self._stop_pool()
            raise
        threads = [threading.Thread(target=self._guard(self._acquire), args=(driver,), name="acquire",
                                    daemon=True),
                   threading.Thread(target=self._guard(self._localize), name="localize", daemon=True)]
        if self.writer is not None:
            threads.append(threading.Thread(target=self._guard(self._write), name="log", daemon=True))
        for t in threads:
            t.start()
        try:
            while threads[1].is_alive():
                threads[1].join(self.opts.status_period_s)
                self._report()
        finally:
            self.stop.set()
            for t in threads:
                t.join(timeout=10)
            self._stop_pool()
            if self.arm is not None:
                self.arm.close()
            if self.live is not None:
                self.live.close()
            self._report(final=True)
            if self.writer is not None:
                self.writer.write_diagnostics(self.status.to_dict(), time.time_ns())   # the final counters
                self.writer.close()
        if self.error is not None:
            raise self.error
        return self.status

    def _guard(self, fn):
        """Run ``fn`` in a thread; an unexpected error stops the loop and is re-raised by run()."""
        def target(*args):
            try:
                fn(*args)
            except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread
                self.error = self.error or exc
                self.stop.set()
        return target

    def _check_size(self, driver) -> None:
        info = driver.info
        w, h = self.calib.image_size
        if info.width_px and (info.width_px, info.height_px) != (w, h):
            raise AcquireError(f"{info.device}: delivers {info.width_px}x{info.height_px} images, "
                               f"the calibration is for {w}x{h}")

    def _open_writer(self, driver):
        if self.opts.log_dir is None:
            return None
        from appliance.logs import LogWriter

        device = dict(dataclasses.asdict(driver.info), variant=self.opts.variant)
        writer = LogWriter(self.opts.log_dir, self.cfg.logging, calibration=self.calib,
                           config_dict=config_to_dict(self.cfg), device=device,
                           version=software_version())
        self.status.logging = True
        return writer

    def _start_pool(self) -> ProcessPoolExecutor | None:
        """The localizer processes, started and ready (each has built its Localizer)."""
        if self.opts.workers == 1:
            return None
        spawn = multiprocessing.get_context("spawn")     # not fork: this process runs threads
        pool = ProcessPoolExecutor(self.opts.workers, mp_context=spawn, initializer=_start_worker,
                                   initargs=(self.calib, self.cfg.localize, self.opts.variant))
        for future in [pool.submit(time.sleep, 0.2) for _ in range(self.opts.workers)]:
            future.result()                             # one task per process: all of them started
        w, h = self.calib.image_size
        # at most `workers` + 1 pairs in flight (_localize_all): one slot more is never being read
        self.shared = SharedFrames(self.opts.workers + 2, (h, w, 3))
        return pool

    def _stop_pool(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(cancel_futures=True)
            self.shared.close()

    def _open_live(self):
        if self.opts.live_port is None:
            return None
        from appliance.live import LiveServer

        return LiveServer("127.0.0.1", self.opts.live_port, calibration=self.calib,
                          jpeg_quality=self.cfg.logging.jpeg_quality)

    def _open_arm(self):
        if self.cfg.serial.port is None:
            return None
        from appliance.arm.link import ArmLink

        link = ArmLink(self.cfg.serial, self.camera_to_base)
        link.set_status(camera_ok=True, calibrated=True, rate_hz=0.0)   # the HELLO's first heartbeat
        link.open()
        return link

    # -- threads -------------------------------------------------------------------------
    def _acquire(self, driver) -> None:
        """Read pairs; reopen a lost camera with back-off; hand pairs to the localizer."""
        wanted = self.opts.frames
        try:
            while not self.stop.is_set():
                try:
                    for frame in driver:
                        self._put_frame(frame)
                        if self.stop.is_set() or (wanted is not None and self.status.pairs >= wanted):
                            return
                    return                                  # a replay ended
                except AcquireError as exc:                 # lost mid-run: reconnect
                    self.status.camera_ok = False
                    self._note(f"camera lost: {exc}")
                    driver.close()
                    driver = self._reopen()
                    if driver is None:
                        return
                    self.status.camera_ok = True
                    self.status.reconnects += 1
                    self._note(f"camera back after {self.status.reconnects} reconnect(s)")
        finally:
            self.status.dropped_driver += getattr(driver, "dropped_pairs", 0) if driver else 0
            if driver is not None:
                driver.close()
            _finish(self.frames_q)

    def _reopen(self):
        delay_s = self.cfg.camera.reconnect_min_s
        while not self.stop.wait(delay_s):
            try:
                return open_driver(self.opts.device, self.cfg.camera)
            except AcquireError:
                delay_s = min(2 * delay_s, self.cfg.camera.reconnect_max_s)
        return None

    def _put_frame(self, frame: StereoFrame) -> None:
        item = (frame, time.monotonic_ns())
        if self.replay:                                     # wait for the localizer, unless stopping
            while not self.stop.is_set():
                try:
                    self.frames_q.put(item, timeout=0.1)
                    self.status.pairs += 1
                    return
                except queue.Full:
                    continue
            return
        self.status.pairs += 1
        while True:
            try:
                self.frames_q.put_nowait(item)
                return
            except queue.Full:                              # newest wins
                try:
                    self.frames_q.get_nowait()
                    self.status.dropped_localize += 1
                except queue.Empty:
                    pass

    def _localize(self) -> None:
        try:
            self._localize_all()
        finally:
            if self.writer is not None:
                _finish(self.log_q)

    def _localize_all(self) -> None:
        """Localize every pair in order: here, or in ``opts.workers`` processes (results kept in order)."""
        if self.opts.workers == 1:
            while (item := self.frames_q.get()) is not _END:
                frame, received_ns = item
                self._emit(frame, received_ns, self._result_of(
                    frame, lambda: self.localizer.localize(frame.left, frame.right, stamp_ns=frame.stamp_ns)))
            return
        pending: deque = deque()                        # (frame, received_ns, future), oldest first
        while (item := self.frames_q.get()) is not _END:
            frame, received_ns = item
            pair = self.shared.put(frame.left, frame.right) or (frame.left, frame.right)
            pending.append((frame, received_ns, self.pool.submit(_localize_in_worker, pair, frame.stamp_ns)))
            # one pair more than workers may wait in the pool: a pair that takes a worker longer
            # (the machine is busy) then delays the next instead of dropping it
            while pending and (len(pending) > self.opts.workers or pending[0][2].done()):
                frame, received_ns, future = pending.popleft()
                self._emit(frame, received_ns, self._result_of(frame, future.result))
        for frame, received_ns, future in pending:
            self._emit(frame, received_ns, self._result_of(frame, future.result))

    def _result_of(self, frame: StereoFrame, localize: Callable):
        """``localize()``'s result for one pair, or None when it raised (counted, noted, skipped).

        Raises
        ------
        LocalizeFailed
            The localizer failed on ``MAX_FAILED_IN_ROW`` pairs in a row.
        """
        try:
            result = localize()
        except Exception as exc:                        # one bad pair must not blind the arm for good
            self.status.failed_localize += 1
            self._failed_in_row += 1
            what = f"pair {frame.seq} (stamp_ns {frame.stamp_ns}): {type(exc).__name__}: {exc}"
            self._note(f"localize failed on {what}")
            if self._failed_in_row >= MAX_FAILED_IN_ROW:
                raise LocalizeFailed(f"{self.opts.device}: the localizer failed on {self._failed_in_row} pairs "
                                     f"in a row, the last {what}") from exc
            return None
        self._failed_in_row = 0
        return result

    def _emit(self, frame: StereoFrame, received_ns: int, result) -> None:
        """Hand one result to the outputs (arm, live view, log) and count it; None: log the frames only."""
        if result is None:                              # the localizer failed: the arm hears nothing
            if self.writer is not None:
                try:
                    self.log_q.put_nowait((frame, None))
                except queue.Full:
                    self.status.dropped_log += 1
            return
        if self.replay:                                 # replayed stamps: time from arrival
            age_ns = time.monotonic_ns() - received_ns
        else:
            age_ns = time.time_ns() - frame.stamp_ns
        self._latency_ms.append(age_ns / 1e6)
        self._done_ns.append(time.monotonic_ns())
        s = self.status
        s.localized += 1
        s.features, s.branches = len(result.features), len(result.branches)
        if self.arm is not None:
            self.arm.submit(result, frame.seq)
        if self.live is not None:                       # never blocks: its own worker
            self.live.write_frame(frame)
            self.live.write_result(result, frame.seq, self.camera_to_base)
        if self.writer is not None:
            try:
                self.log_q.put_nowait((frame, result))
            except queue.Full:
                s.dropped_log += 1

    def _write(self) -> None:
        while True:
            item = self.log_q.get()
            if item is _END:
                return
            if isinstance(item, dict):
                self.writer.write_diagnostics(item, time.time_ns())
                continue
            frame, result = item
            self.writer.write_frame(frame)
            if result is not None:
                self.writer.write_result(result, frame.seq, self.camera_to_base)

    # -- status --------------------------------------------------------------------------
    def _note(self, message: str) -> None:
        if self.writer is not None:
            try:
                self.log_q.put_nowait({"message": message})
            except queue.Full:
                pass

    def _report(self, final: bool = False) -> None:
        s = self.status
        done = list(self._done_ns)
        s.rate_hz = (len(done) - 1) / ((done[-1] - done[0]) / 1e9) if len(done) > 1 and done[-1] > done[0] \
            else 0.0
        if self._latency_ms:
            s.latency_p50_ms, s.latency_p99_ms = np.percentile(list(self._latency_ms), [50, 99]).tolist()
        if self.arm is not None:
            if not final:
                self.arm.set_status(camera_ok=s.camera_ok, calibrated=True, rate_hz=s.rate_hz)
            s.arm = self.arm.stats()
        if self.writer is not None:
            s.log_paths = [str(p) for p in self.writer.paths]
            s.logging = not self.writer.stopped
            if not final:
                try:
                    self.log_q.put_nowait(s.to_dict())
                except queue.Full:
                    pass
        if self.live is not None:
            s.live = self.live.stats()
            if not final:
                self.live.write_diagnostics(s.to_dict(), time.time_ns())
        if self.on_status is not None:
            self.on_status(replace(s, arm=dict(s.arm), log_paths=list(s.log_paths), live=dict(s.live)))
