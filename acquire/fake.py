"""The fake driver: replays recorded pairs so nothing needs a camera.

``fake:PATH`` replays
- a folder of left/right images (paired by name, :func:`appliance.acquire.pairs.find_pairs`),
- a side-by-side video file (split like a UVC stereo camera),
- an MCAP log written by the appliance (:func:`appliance.logs.iter_stereo_frames`).

Rate (``camera.fake_rate_hz``): 0 replays MCAP at its recorded pace, a folder at 10 Hz and a
video at its own frame rate; > 0 at that fixed rate; < 0 as fast as possible.

Stamps: a folder or video is stamped ``start + seq * period`` from the wall clock
(CLOCK_REALTIME, ns) at the first frame, with ``period`` the replay period (the nominal one
above when running as fast as possible). An MCAP log keeps its recorded stamps; when it loops,
each lap is shifted by the log's length plus one frame period so stamps keep increasing.
With ``camera.fake_restamp`` the MCAP stamps are instead moved onto the replay clock
(``start + (recorded - first recorded)``), keeping the recorded left/right skew.
``seq`` counts the delivered pairs from 0. Pairs whose left/right stamps differ by more
than ``camera.max_stereo_skew_ms`` are dropped and counted, as with live cameras.
Without ``camera.fake_loop`` iteration ends after the last pair; with it, a folder's images are
decoded once, when the driver opens (up to ``FOLDER_CACHE_BYTES``), and delivered read-only, so
a loop over a few pairs costs no decoding and even its first lap keeps the camera's pace.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Iterator

import cv2
import numpy as np

from appliance.acquire.driver import DriverBase
from appliance.acquire.frame import (
    AcquireError, DeviceLost, DeviceNotFound, DriverInfo, FormatNotSupported, StereoFrame,
)
from appliance.acquire.images import split_side_by_side
from appliance.acquire.pairs import find_pairs

FOLDER_RATE_HZ = 10.0
FOLDER_CACHE_BYTES = 512 * 2**20   # a looping folder's images are decoded once, up to this much memory

# One lap of a source: (left, right, stamp_left_ns, stamp_right_ns); stamps None = synthesize.
Item = tuple[np.ndarray, np.ndarray, "int | None", "int | None"]


class FakeDriver(DriverBase):
    """Replay a folder, a side-by-side video or an MCAP log (see the module docstring).

    Parameters
    ----------
    path : str
        What ``fake:PATH`` names.
    cfg : CameraConfig
        Uses ``fake_rate_hz``, ``fake_loop``, ``fake_restamp``, ``max_stereo_skew_ms``,
        ``side_by_side_left_half``.
    """

    def __init__(self, path: str, cfg):
        self.name = f"fake:{path}"
        self.path = Path(path)
        self.cfg = cfg
        self.dropped_pairs = 0
        self._decoded: dict[int, tuple[np.ndarray, np.ndarray]] = {}   # looping folder: pair index -> images
        if not self.path.exists():
            raise DeviceNotFound(f"{self.name}: no such folder or file")
        if self.path.is_dir():
            self._pairs, _ = find_pairs(self.path)
            if not self._pairs:
                raise DeviceNotFound(f"{self.name}: no left/right image pairs in this folder "
                                     "(names like left_00.png/right_00.png)")
            self._lap, nominal_hz = self._folder, FOLDER_RATE_HZ
        elif self.path.suffix.lower() == ".mcap":
            self._lap, nominal_hz = self._mcap, None  # paced by its recorded stamps
        else:
            cap = cv2.VideoCapture(str(self.path))
            fps = cap.get(cv2.CAP_PROP_FPS) if cap.isOpened() else 0.0
            cap.release()
            if fps <= 0:
                raise FormatNotSupported(f"{self.name}: not a folder, an .mcap log or a video "
                                         "OpenCV can read")
            self._lap, nominal_hz = self._video, fps
        lap = self._lap()
        first = next(lap, None)
        if self._lap == self._folder and cfg.fake_loop:
            try:                    # decode the whole looping folder now: the first lap is then on time
                for _ in lap:
                    pass
            except DeviceLost:      # an unreadable image: the camera is lost when the lap reaches it
                pass
        lap.close()
        if first is None:
            raise DeviceNotFound(f"{self.name}: holds no stereo frames")
        rate = cfg.fake_rate_hz
        self._period_s = 1.0 / rate if rate > 0 else (1.0 / nominal_hz if nominal_hz else None)
        self._paced = rate >= 0
        left = first[0]
        fmt = "BGR8" if left.ndim == 3 else "MONO8"
        fps_hz = rate if rate > 0 else (nominal_hz or 0.0)
        self.info = DriverInfo("fake", self.name, left.shape[1], left.shape[0], fmt, fps_hz)

    # -- sources: one lap each ------------------------------------------------------------
    def _folder(self) -> Iterator[Item]:
        for i, pair in enumerate(self._pairs):
            if i in self._decoded:
                yield *self._decoded[i], None, None
                continue
            left = cv2.imread(str(pair.left), cv2.IMREAD_COLOR)
            right = cv2.imread(str(pair.right), cv2.IMREAD_COLOR)
            if left is None or right is None:
                bad = pair.left if left is None else pair.right
                raise DeviceLost(f"{self.name}: cannot read image {bad.name}")
            cached = sum(a.nbytes + b.nbytes for a, b in self._decoded.values())
            if self.cfg.fake_loop and cached + left.nbytes + right.nbytes <= FOLDER_CACHE_BYTES:
                left.flags.writeable = right.flags.writeable = False    # shared by every lap
                self._decoded[i] = (left, right)
            yield left, right, None, None

    def _video(self) -> Iterator[Item]:
        cap = cv2.VideoCapture(str(self.path))
        try:
            while True:
                ok, frame = cap.read()
                if not ok:
                    return
                left, right = split_side_by_side(frame, self.cfg.side_by_side_left_half)
                yield left, right, None, None
        finally:
            cap.release()

    def _mcap(self) -> Iterator[Item]:
        try:
            from appliance.logs import iter_stereo_frames
        except ImportError as exc:
            raise AcquireError(f"{self.name}: MCAP replay needs appliance.logs ({exc})") from None
        try:
            for frame in iter_stereo_frames(self.path):
                yield frame.left, frame.right, frame.stamp_left_ns, frame.stamp_right_ns
        except AcquireError:
            raise
        except Exception as exc:  # noqa: BLE001 - any reader failure is a one-line error naming the log
            raise FormatNotSupported(f"{self.name}: cannot read stereo frames: {exc}") from None

    # -- replay -------------------------------------------------------------------------
    def __iter__(self) -> Iterator[StereoFrame]:
        max_skew_ns = int(self.cfg.max_stereo_skew_ms * 1e6)
        start_ns, start_mono = time.time_ns(), time.monotonic()
        seq = n = 0         # n: items taken from the source (synthetic stamps and pacing)
        lap_shift_ns = 0    # recorded stamps: added per lap so stamps keep increasing
        first_ns = None     # the first recorded stamp
        while True:
            lap_ns = []     # this lap's recorded left stamps
            for left, right, stamp_l, stamp_r in self._lap():
                if stamp_l is None:
                    stamp_l = stamp_r = start_ns + round(n * self._period_s * 1e9)
                    due_s = n * self._period_s
                else:
                    first_ns = stamp_l if first_ns is None else first_ns
                    lap_ns.append(stamp_l)
                    stamp_l, stamp_r = stamp_l + lap_shift_ns, stamp_r + lap_shift_ns
                    due_s = (stamp_l - first_ns) / 1e9 if self._period_s is None else n * self._period_s
                    if self.cfg.fake_restamp:
                        stamp_l, stamp_r = (start_ns + s - first_ns for s in (stamp_l, stamp_r))
                n += 1
                if abs(stamp_l - stamp_r) > max_skew_ns:
                    self.dropped_pairs += 1
                    continue
                if self._paced:
                    wait_s = start_mono + due_s - time.monotonic()
                    if wait_s > 0:
                        time.sleep(wait_s)
                yield StereoFrame(left, right, seq, stamp_l, stamp_r)
                seq += 1
            if not self.cfg.fake_loop or n == 0:
                return
            if lap_ns:
                steps = np.diff(lap_ns)
                step_ns = int(np.median(steps)) if len(steps) else round((self._period_s or 0.1) * 1e9)
                lap_shift_ns += lap_ns[-1] - lap_ns[0] + step_ns

    def close(self) -> None:
        """Nothing to release: each lap opens and closes its own files."""

