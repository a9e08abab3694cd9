"""GigE Vision cameras through Aravis (optional: ``pip install '.[gige]'``, see docs/acquire.md).

Cameras are opened BY ADDRESS only (``Aravis.GvDevice.new``): nothing here calls Aravis'
device discovery (``update_device_list``, ``Camera.new(None)``), which broadcasts to
255.255.255.255 on every interface.

Stamps are the buffer's *system* timestamp: the host's CLOCK_REALTIME when the frame's
leader packet arrived, in ns. Device timestamps are not used: two cameras' clocks are not
synchronised unless PTP is set up, so host time is what can pair two cameras.
"""

from __future__ import annotations

import socket
import threading

import numpy as np

from appliance.acquire.driver import CameraInfo
from appliance.acquire.frame import AcquireError, DeviceLost, DeviceNotFound, FormatNotSupported
from appliance.acquire.images import GENICAM_FORMAT, buffer_to_array, to_bgr

GVCP_PORT = 3956
NEEDS = ("GigE support needs Aravis 0.8 and PyGObject: apt-get install gir1.2-aravis-0.8 "
         "libgirepository1.0-dev libcairo2-dev pkg-config, then pip install 'appliance[gige]' "
         "(docs/acquire.md)")


def load_aravis():
    """The ``Aravis`` GObject-introspection module; :class:`AcquireError` says what is missing."""
    try:
        import aravis  # noqa: F401 - PyPI's aravis-python, if installed, brings its own libaravis
    except ImportError:
        pass
    try:
        import gi

        gi.require_version("Aravis", "0.8")
        from gi.repository import Aravis
    except (ImportError, ValueError) as exc:
        raise AcquireError(f"{NEEDS}; here: {exc}") from None
    return Aravis


def local_address_for(address: str) -> str:
    """The local IPv4 address the kernel routes to ``address`` (a UDP connect sends nothing)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.connect((address, GVCP_PORT))
        return s.getsockname()[0]


class AravisCamera:
    """One GigE Vision camera, opened by address.

    Parameters
    ----------
    address : str
        IPv4 address or host name of the camera.
    width_px, height_px : int
        Region asked for (twice one camera's width for a side-by-side camera).
    fps_hz : float
        AcquisitionFrameRate asked for.
    pixel_format : "MONO8" | "BAYER_RG8" | "RGB8"
        camera.pixel_format; images are converted to BGR.
    open_timeout_s : float
        The first frame must arrive within this time (and every later one, or DeviceLost).
    buffers : int
        Stream buffers queued to Aravis.
    """

    def __init__(self, address: str, width_px: int, height_px: int, fps_hz: float, pixel_format: str,
                 open_timeout_s: float, buffers: int = 8):
        self.name = f"gige:{address}"
        self._camera = self._stream = None
        self._lost = False
        if pixel_format not in GENICAM_FORMAT:
            raise FormatNotSupported(f"{self.name}: camera.pixel_format {pixel_format} is not a GigE format "
                                     f"(use {' | '.join(GENICAM_FORMAT)})")
        Aravis = load_aravis()
        from gi.repository import GLib, Gio

        self._timeout_us = int(open_timeout_s * 1e6)
        self.frames = self.incomplete = 0
        try:
            ip = socket.gethostbyname(address)
            device = Aravis.GvDevice.new(Gio.InetAddress.new_from_string(local_address_for(ip)),
                                         Gio.InetAddress.new_from_string(ip))
            camera = Aravis.Camera.new_with_device(device)
        except (OSError, GLib.Error) as exc:
            raise DeviceNotFound(f"{self.name}: no GigE Vision camera answers at {address} "
                                 f"({getattr(exc, 'message', exc)})") from None
        self._camera = camera
        self._format = GENICAM_FORMAT[pixel_format]
        available = camera.dup_available_pixel_formats_as_strings() or []
        if self._format not in available:
            raise FormatNotSupported(f"{self.name}: pixel format {self._format} not offered "
                                     f"(camera has {', '.join(available)})")
        try:
            camera.set_pixel_format_from_string(self._format)
            camera.set_region(0, 0, width_px, height_px)
            camera.set_frame_rate(fps_hz)
        except GLib.Error as exc:
            raise FormatNotSupported(f"{self.name}: refuses {width_px}x{height_px} {self._format} at "
                                     f"{fps_hz:g} Hz ({exc.message})") from None
        region = camera.get_region()
        if (region.width, region.height) != (width_px, height_px):
            raise FormatNotSupported(f"{self.name}: delivers {region.width}x{region.height}, "
                                     f"not the {width_px}x{height_px} asked for")
        self._stream = camera.create_stream(None, None)
        payload = camera.get_payload()
        for _ in range(buffers):
            self._stream.push_buffer(Aravis.Buffer.new_allocate(payload))
        self._success = Aravis.BufferStatus.SUCCESS
        camera.start_acquisition()
        self.info = CameraInfo(width_px, height_px, self._format, camera.get_frame_rate(),
                               camera.get_device_serial_number() or "")
        try:
            self._pending = self.read()
        except DeviceLost:
            self.close()
            raise DeviceNotFound(f"{self.name}: opened but delivered no frame within {open_timeout_s:g} s "
                                 "(camera.open_timeout_s)") from None
        self.frames = 0

    def read(self) -> tuple[int, np.ndarray]:
        """The next ``(stamp_ns, BGR image)``; frames with missing packets are skipped and counted."""
        if getattr(self, "_pending", None) is not None:
            item, self._pending = self._pending, None
            self.frames += 1
            return item
        while True:
            buffer = self._stream.timeout_pop_buffer(self._timeout_us) if self._stream else None
            if buffer is None:
                self._lost = True
                raise DeviceLost(f"{self.name}: no frame for {self._timeout_us / 1e6:g} s after "
                                 f"{self.frames} (cable, power or bandwidth?)")
            try:
                if buffer.get_status() != self._success:
                    self.incomplete += 1
                    continue
                raw = buffer_to_array(buffer.get_data(), buffer.get_image_width(), buffer.get_image_height(),
                                      self._format)
                image = to_bgr(raw, self._format)
                stamp_ns = buffer.get_system_timestamp()
            finally:
                self._stream.push_buffer(buffer)
            self.frames += 1
            return stamp_ns, image

    def close(self) -> None:
        # a lost camera is not told to stop: each unanswered GVCP command costs seconds of retries
        if self._camera is not None and not self._lost:
            try:
                self._camera.stop_acquisition()
            except Exception:  # noqa: BLE001 - a lost camera cannot be stopped; closing must go on
                pass
        held = [self._stream, self._camera]
        self._stream = self._camera = None
        if self._lost:
            # Releasing a lost camera retries GVCP commands for seconds: let a thread wait for it
            # so the run loop can reconnect at once.
            threading.Thread(target=held.clear, daemon=True, name=f"release-{self.name}").start()
