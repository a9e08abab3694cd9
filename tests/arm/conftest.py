"""Fixtures of the arm tests: a pty pair joined like a cable, the simulator as a real process."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # armtest.py, ptybridge.py
from armtest import SimProcess  # noqa: E402
from ptybridge import PtyBridge  # noqa: E402


@pytest.fixture
def bridge(tmp_path):
    b = PtyBridge(tmp_path)
    yield b
    b.close()


@pytest.fixture
def start_sim():
    """Start SimProcess(...) instances that are killed at teardown even when the test fails."""
    sims = []

    def start(*args, **kwargs):
        sims.append(SimProcess(*args, **kwargs))
        sims[-1].wait_for(lambda evs: any(e["event"] == "port_open" for e in evs), "arm-sim to open its port")
        return sims[-1]

    yield start
    for sim in sims:
        if sim.proc.poll() is None:
            sim.proc.kill()
            sim.proc.wait()
