"""Pair two streams of stamped images by nearest capture time."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any


@dataclass
class StampPairer:
    """Match left and right images whose stamps are nearest, within ``max_skew_ns``.

    Images are pushed per side in capture order; :meth:`pop` returns the pairs that are
    final. An image that cannot get a partner within the skew (its partner was lost, or
    the other side runs at another rate) is dropped and counted in ``dropped``; an image is
    never paired with anything but its nearest partner known at the time: heads within the
    skew are paired at once (no added latency), which is the nearest partner whenever
    ``max_skew_ns`` is below half the frame period, as it should be.

    Images older than the other side's first image are the start-up backlog of the camera
    that started first: they are dropped but not counted.

    Parameters
    ----------
    max_skew_ns : int
        Largest allowed ``|stamp_left_ns - stamp_right_ns|``, ns.
    """

    max_skew_ns: int
    dropped: int = 0
    dropped_in_row: int = 0  # drops since the last pair
    _sides: tuple[deque, deque] = field(default_factory=lambda: (deque(), deque()))
    _first_ns: list = field(default_factory=lambda: [None, None])

    def push(self, side: int, stamp_ns: int, image: Any) -> None:
        """Add an image of ``side`` (0 left, 1 right); stamps of one side must not decrease."""
        if self._first_ns[side] is None:
            self._first_ns[side] = stamp_ns
        self._sides[side].append((stamp_ns, image))

    def pending(self, side: int) -> int:
        """Images of ``side`` waiting for a partner."""
        return len(self._sides[side])

    def pop(self) -> list[tuple[tuple[int, Any], tuple[int, Any]]]:
        """Pairs ``((stamp_left_ns, left), (stamp_right_ns, right))`` that are now final."""
        left, right = self._sides
        pairs = []
        while left and right:
            (tl, _), (tr, _) = left[0], right[0]
            # The older head is dropped when a later image of its own side is at least as
            # near to the other head: that later one is the better partner.
            older, t_old, t_other, other_side = (left, tl, tr, 1) if tl <= tr else (right, tr, tl, 0)
            if t_other - t_old > self.max_skew_ns or (
                len(older) > 1 and abs(older[1][0] - t_other) <= t_other - t_old
            ):
                older.popleft()
                if t_old >= self._first_ns[other_side] - self.max_skew_ns:  # not start-up backlog
                    self.dropped += 1
                    self.dropped_in_row += 1
                continue
            pairs.append((left.popleft(), right.popleft()))
            self.dropped_in_row = 0
        return pairs
