"""Options and helpers shared by the commands."""

from __future__ import annotations

import os
import signal
import threading
from pathlib import Path
from typing import Annotated, Optional

import typer

from appliance.config import Config, load_config
from appliance.errors import ApplianceError

ConfigOption = Annotated[
    Optional[Path],
    typer.Option("--config", "-c", help="YAML file overlaid on the default configuration."),
]


def effective_config(path: Path | None) -> Config:
    """The default configuration overlaid with ``path`` (raises ConfigError)."""
    return load_config(path)


def output_paths(*paths: Path | None) -> None:
    """Make each output file's folder and check it can be written, before the work that fills the file: a
    long job must not end on an unwritable output (raises ApplianceError naming the file). ``None`` entries
    (outputs not asked for) are skipped."""
    for path in paths:
        if path is None:
            continue
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise ApplianceError(f"{path}: cannot make its folder {path.parent} ({e.strerror or e})") from None
        if not os.access(path.parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
            raise ApplianceError(f"{path}: cannot be written")


def stop_on_signals(stop: threading.Event, signals=(signal.SIGINT, signal.SIGTERM)) -> None:
    """Set ``stop`` on the first of ``signals``; a second one ends the process at once (its default action: the
    user means it, say a run stuck on a dead device). Call from the main thread.

    The event is set by a watcher thread woken through ``signal.set_wakeup_fd``, never by the handler
    itself: a handler runs on the main thread between two bytecodes, and if that thread was inside
    ``stop.wait()`` holding the event's lock (which is not reentrant), ``stop.set()`` there waits for it
    forever (seen on about one SIGTERM in 300 to a loop of short waits).
    """
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    signal.set_wakeup_fd(write_fd)
    received = []

    def on_signal(signum, _frame) -> None:
        received.append(signum)           # (no lock taken here: see above)
        if len(received) > 1:
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)

    for sig in signals:
        signal.signal(sig, on_signal)
    wanted = {int(s) for s in signals}

    def watch() -> None:
        while not set(os.read(read_fd, 64)) & wanted:
            pass
        stop.set()

    threading.Thread(target=watch, name="stop-on-signals", daemon=True).start()
