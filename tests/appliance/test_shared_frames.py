"""Pairs handed to real worker processes through shared memory."""

from __future__ import annotations

import multiprocessing
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from appliance.shared_frames import SharedFrames

sys.path.insert(0, str(Path(__file__).parent))   # shm_worker.py, importable in spawned workers too
from shm_worker import sums  # noqa: E402


def test_workers_read_each_pair_in_its_slot_and_the_block_is_freed():
    shape = (6, 8, 3)
    frames = SharedFrames(3, shape)
    name = frames._shm.name
    rng = np.random.default_rng(0)
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        pending = []
        for _ in range(7):
            left, right = (rng.integers(0, 256, shape, dtype=np.uint8) for _ in range(2))
            pending.append((pool.submit(sums, frames.put(left, right)), int(left.sum()), int(right.sum())))
            if len(pending) == 2:                      # at most two in flight, as the run loop
                future, *want = pending.pop(0)
                assert list(future.result()[1:]) == want
        slots = [f.result()[0] for f, *_ in pending]
    assert slots == [0]                                # round robin: 7 pairs in 3 slots, the 7th in slot 0
    assert frames.put(np.zeros((6, 8), np.uint8), np.zeros((6, 8), np.uint8)) is None   # other shape: not here
    assert frames.put(np.zeros(shape, np.uint16), np.zeros(shape, np.uint16)) is None
    frames.close()
    assert not Path("/dev/shm", name.lstrip("/")).exists()
