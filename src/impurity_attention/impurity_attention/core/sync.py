"""Pairing of colour and depth frames by stamp (message_filters is not in the pip ROS wheels).

The camera publishes colour and aligned depth with the same stamp; they arrive on separate topics in
any order. Each side keeps its few latest frames; a frame pairs with the other side's frame whose
stamp is closest and within `tolerance_ns`. Older unpaired frames are dropped with the pair so that
a lost message never holds the buffer back.
"""

from __future__ import annotations

from collections import OrderedDict


class StampPairer:
    def __init__(self, tolerance_ns: int = 0, capacity: int = 5):
        if tolerance_ns < 0 or capacity < 1:
            raise ValueError("need tolerance_ns >= 0 and capacity >= 1")
        self.tolerance_ns, self.capacity = int(tolerance_ns), int(capacity)
        self._waiting = {"color": OrderedDict(), "depth": OrderedDict()}
        self.dropped = 0  # frames discarded unpaired (overflow or overtaken)

    def add_color(self, stamp_ns: int, item):
        """Returns (color, depth) when `item` completes a pair, else None."""
        return self._add("color", "depth", stamp_ns, item)

    def add_depth(self, stamp_ns: int, item):
        pair = self._add("depth", "color", stamp_ns, item)
        return None if pair is None else (pair[1], pair[0])

    def _add(self, side: str, other: str, stamp_ns: int, item):
        candidates = self._waiting[other]
        best = None
        for stamp in candidates:
            gap = abs(stamp - stamp_ns)
            if gap <= self.tolerance_ns and (best is None or gap < abs(best - stamp_ns)):
                best = stamp
        if best is None:
            queue = self._waiting[side]
            queue[stamp_ns] = item
            while len(queue) > self.capacity:
                queue.popitem(last=False)
                self.dropped += 1
            return None
        partner = candidates.pop(best)
        # everything older than the pair on either side can never pair any more
        for queue in self._waiting.values():
            for stamp in [s for s in queue if s < min(best, stamp_ns)]:
                del queue[stamp]
                self.dropped += 1
        return item, partner

    def clear(self):
        for queue in self._waiting.values():
            queue.clear()
