"""Helpers of the arm tests: configs, results, the simulator as a real process."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from appliance.config import load_config
from appliance.localize.result import Branch, LocalizationResult

APPLIANCE = Path(sys.executable).with_name("appliance")
REPO_FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"


def serial_cfg(port, **changes):
    """The default serial config on ``port`` with fast back-off, changed as given."""
    cfg = load_config().serial
    return replace(cfg, port=str(port), reconnect_min_s=0.05, reconnect_max_s=0.2, **changes)


def make_result(i: int) -> LocalizationResult:
    """Result number ``i``: two branches, the nearer one first after sorting."""
    far = Branch(10, (-1, -1), np.array([[0.0, -50, 1200 + i], [0.0, 50, 1200 + i]]), 8.0)
    near = Branch(11, (-1, -1), np.array([[40.0, 0, 700], [40.0, 30, 720], [90, 30, 720]]), 4.0, True)
    return LocalizationResult((), (far, near), stamp_ns=1_000_000_000 + i)


def _die_with_parent() -> None:
    """In the child: SIGTERM when the test process dies, so no simulator outlives a killed run
    (one left behind would reopen its port name, which a later test's pty may then reuse)."""
    import ctypes

    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


class SimProcess:
    """``appliance arm-sim PORT --json-out FILE`` as a real process; ``stop()`` returns its events."""

    def __init__(self, port, out: Path, *args: str):
        self.out = out
        self.proc = subprocess.Popen([str(APPLIANCE), "arm-sim", str(port), "--json-out", str(out), *args],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     preexec_fn=_die_with_parent)

    def events(self) -> list[dict]:
        if not self.out.exists():
            return []
        lines = self.out.read_text().splitlines()
        return [json.loads(line) for line in lines if line.endswith("}")]

    def obstacles(self) -> list[dict]:
        return [e for e in self.events() if e.get("type") == "OBSTACLES"]

    def wait_for(self, predicate, what: str, timeout_s: float = 60.0) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if predicate(self.events()):
                return
            assert self.proc.poll() is None, f"arm-sim exited: {self.proc.communicate()}"
            time.sleep(0.02)
        raise AssertionError(f"timed out waiting for {what}")

    def stop(self) -> tuple[str, str]:
        self.proc.send_signal(signal.SIGTERM)
        out, err = self.proc.communicate(timeout=60)     # generous: a loaded machine, not a slow sim, is the risk
        assert self.proc.returncode == 0, err
        return out, err
