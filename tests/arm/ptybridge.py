"""Two pseudo-terminals joined like a null-modem cable, with stable symlinked names.

The link opens ``link_path``, the simulator ``sim_path`` (both with pyserial, as real
ports). ``unplug()`` closes the link side's pty (its device node vanishes, the open port
fails with EIO like an unplugged USB adapter); ``replug()`` makes a new pty under the same
name, as udev does for /dev/serial/by-id links.
"""

from __future__ import annotations

import os
import select
import threading
import tty
from pathlib import Path


def _new_pty(path: Path) -> tuple[int, int]:
    master, slave = os.openpty()
    tty.setraw(slave)  # no echo or line editing before pyserial configures it
    tmp = path.with_suffix(".new")
    tmp.unlink(missing_ok=True)
    tmp.symlink_to(os.ttyname(slave))
    tmp.replace(path)
    return master, slave


class PtyBridge:
    def __init__(self, folder: Path):
        self.link_path, self.sim_path = folder / "ttyLINK", folder / "ttySIM"
        self._lock = threading.Lock()
        self._link = _new_pty(self.link_path)
        self._sim = _new_pty(self.sim_path)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._relay, daemon=True)
        self._thread.start()

    def unplug(self) -> None:
        with self._lock:
            for fd in self._link:
                os.close(fd)
            self._link = None
            self.link_path.unlink()

    def replug(self) -> None:
        with self._lock:
            self._link = _new_pty(self.link_path)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        # no stale name may lead a straggler to a later test's pty that reuses the number
        self.link_path.unlink(missing_ok=True)
        self.sim_path.unlink(missing_ok=True)
        with self._lock:
            for pair in (self._link, self._sim):
                for fd in pair or ():
                    os.close(fd)

    def _relay(self) -> None:
        while not self._stop.is_set():
            with self._lock:
                if self._link is None:
                    pairs = {}
                else:
                    pairs = {self._link[0]: self._sim[0], self._sim[0]: self._link[0]}
            if not pairs:
                self._stop.wait(0.005)
                continue
            ready, _, _ = select.select(list(pairs), [], [], 0.01)
            with self._lock:
                if self._link is None or self._link[0] not in pairs:
                    continue  # unplugged meanwhile: whatever was in flight is lost
                for fd in ready:
                    try:
                        data = os.read(fd, 65536)
                    except OSError:
                        continue
                    os.write(pairs[fd], data)
