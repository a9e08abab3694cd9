"""Stereo pairs handed to localizer processes through shared memory instead of a pipe.

A 1280x960 pair is 7.4 MB: pickled through a process pool's pipe it costs ~9 ms of CPU per
pair (pickling, and the pipe's copies on both sides), a quarter of a core at 30 pairs/s.
Here the loop copies each pair once into a slot of one shared block and sends only the slot's
number; the worker reads the slot in place.

Slots are used round robin: with at most ``n_slots - 1`` pairs in flight, the slot written
next is never one a worker is reading.
"""

from __future__ import annotations

from dataclasses import dataclass
from multiprocessing import shared_memory

import numpy as np


@dataclass(frozen=True)
class SlotRef:
    """What a worker needs to read one slot: the block's name, the slot and the images' shape."""

    name: str
    slot: int
    shape: tuple[int, ...]


class SharedFrames:
    """``n_slots`` stereo pairs of ``shape`` (H, W, 3) uint8 in one shared memory block (owner side).

    Parameters
    ----------
    n_slots : int
        Pairs the block holds; more than the pairs ever in flight at once.
    shape : tuple of int
        Shape of one image, (H, W) or (H, W, C); uint8.
    """

    def __init__(self, n_slots: int, shape: tuple[int, ...]):
        self.n_slots, self.shape = n_slots, tuple(int(s) for s in shape)
        self._shm = shared_memory.SharedMemory(create=True, size=n_slots * 2 * int(np.prod(self.shape)))
        self._next = 0

    def put(self, left: np.ndarray, right: np.ndarray) -> SlotRef | None:
        """Copy a pair into the next slot; None when the images do not fit the slots (other
        shape or type): the caller sends that pair itself."""
        if left.shape != self.shape or right.shape != self.shape or left.dtype != np.uint8 \
                or right.dtype != np.uint8:
            return None
        slot = self._next
        self._next = (slot + 1) % self.n_slots
        view = pair_view(self._shm.buf, slot, self.shape)
        view[0], view[1] = left, right
        return SlotRef(self._shm.name, slot, self.shape)

    def close(self) -> None:
        """Free the block (workers must be done with it)."""
        self._shm.close()
        self._shm.unlink()


def pair_view(buf, slot: int, shape: tuple[int, ...]) -> np.ndarray:
    """The (2, *shape) uint8 view of one slot of a block's buffer."""
    size = 2 * int(np.prod(shape))
    return np.ndarray((2, *shape), np.uint8, buffer=buf, offset=slot * size)


def attach(name: str) -> shared_memory.SharedMemory:
    """Open an existing block in a worker process started by the block's owner (which frees it:
    the worker shares the owner's resource tracker, so the block is not freed twice)."""
    return shared_memory.SharedMemory(name=name)
