"""Pairing of colour and depth frames by stamp (message_filters is not in the pip ROS wheels).

The camera publishes colour and aligned depth frames; they arrive on separate topics in any order,
and real drivers do not always give a pair the same stamp (depth stamped some ms after its colour
frame is common). Each side keeps its few latest frames; a colour and a depth frame pair when each
is the other's nearest frame and their stamps lie within the tolerance:

- automatic (the default, `tolerance_ns=None`): `period_fraction` (half) of the frame period measured
  from the stamps themselves (the shortest step between frames of a stream, once seen a few times).
  Within half a period a frame's nearest partner is its own, whatever the driver's offset (below
  half a period); until the period is measured only equal stamps pair, and the frames that wait pair
  as soon as it is. (When frames are lost from the start, the first steps can all be two periods
  long; a period measured that way lets a frame whose partner was lost pair with a neighbour's
  until a one-period step shows up.)
- fixed: `tolerance_ns`.

Frames older than a pair can never pair any more and are dropped with it, so that a lost message
never holds the buffer back. Every frame dropped unpaired is recorded (`take_unpaired`) with the
offset to the nearest frame of the other stream, for the caller to say why.
"""

from __future__ import annotations

from collections import OrderedDict, deque
from dataclasses import dataclass

SIDES = ("color", "depth")
PERIOD_SAMPLES = 30  # stamp steps per stream the frame period is measured over
CONFIRMATIONS = 3  # steps of the shortest length before it is taken as the period


@dataclass(frozen=True)
class UnpairedFrame:
    """A frame dropped without a partner."""

    side: str  # "color" or "depth"
    stamp_ns: int
    offset_ns: int | None  # depth stamp - colour stamp to the nearest frame of the other stream; None: none
    tolerance_ns: int  # the tolerance in force when it was dropped
    nearest_paired: bool  # that nearest frame paired with another one
    others_paired: bool  # frames of the last PERIOD_SAMPLES arrivals paired: pairing works

    @property
    def partner_lost(self) -> bool:
        """Its partner never came (lost in transport, dropped by a slow subscriber) or it came twice;
        otherwise (nothing pairs, the nearest frame is beyond the tolerance) the stamps lie too far
        apart for the tolerance."""
        within = self.offset_ns is not None and abs(self.offset_ns) <= self.tolerance_ns
        return self.nearest_paired or self.others_paired or within


class StampPairer:
    def __init__(self, tolerance_ns: int | None = None, period_fraction: float = 0.5, capacity: int = 5):
        if (tolerance_ns is not None and tolerance_ns < 0) or capacity < 1 or not 0 < period_fraction <= 0.5:
            raise ValueError("need tolerance_ns >= 0 (or None: automatic), 0 < period_fraction <= 0.5 and "
                             "capacity >= 1")
        self.fixed_tolerance_ns = None if tolerance_ns is None else int(tolerance_ns)
        self.period_fraction, self.capacity = float(period_fraction), int(capacity)
        self._waiting = {side: OrderedDict() for side in SIDES}
        self._recent = {side: deque(maxlen=PERIOD_SAMPLES + 1) for side in SIDES}  # latest stamps seen
        self._gaps = {side: deque(maxlen=PERIOD_SAMPLES) for side in SIDES}
        self._paired = {side: deque(maxlen=PERIOD_SAMPLES) for side in SIDES}  # stamps that paired
        self._outcomes = deque(maxlen=PERIOD_SAMPLES)  # per frame gone: True paired, False dropped
        self._pair_offsets = deque(maxlen=PERIOD_SAMPLES)  # depth - colour stamp of the latest pairs
        self._unpaired: list[UnpairedFrame] = []
        self.dropped = 0  # frames discarded unpaired (overflow or overtaken)
        self.paired = 0

    @property
    def period_ns(self) -> int | None:
        """The measured frame period: the shortest recent stamp step of either stream (a lost frame only
        lengthens a step; with two rates, the faster stream's period is what tells its frames apart),
        once CONFIRMATIONS steps that short were seen; None before."""
        gaps = [gap for side in SIDES for gap in self._gaps[side]]
        if not gaps:
            return None
        shortest = min(gaps)
        # a lost frame makes a step of two periods: wait until the shortest step was seen a few times
        confirmed = sum(1 for gap in gaps if gap <= shortest * 1.1) >= CONFIRMATIONS
        return int(shortest) if confirmed else None

    @property
    def pair_offset_ns(self) -> int | None:
        """The median depth - colour stamp difference of the latest pairs; None before the first."""
        if not self._pair_offsets:
            return None
        return int(sorted(self._pair_offsets)[len(self._pair_offsets) // 2])

    @property
    def tolerance_ns(self) -> int:
        """The largest stamp difference that pairs now."""
        if self.fixed_tolerance_ns is not None:
            return self.fixed_tolerance_ns
        period = self.period_ns
        return 0 if period is None else int(self.period_fraction * period)

    def add_color(self, stamp_ns: int, item) -> list:
        """The (color, depth) pairs completed now that `item` arrived, oldest first (usually none or
        one; more when the measured period first lets waiting frames pair)."""
        return self._add("color", int(stamp_ns), item)

    def add_depth(self, stamp_ns: int, item) -> list:
        return self._add("depth", int(stamp_ns), item)

    def take_unpaired(self) -> list[UnpairedFrame]:
        """The frames dropped unpaired since the last call."""
        unpaired, self._unpaired = self._unpaired, []
        return unpaired

    def _add(self, side: str, stamp_ns: int, item) -> list:
        recent = self._recent[side]
        if recent and stamp_ns > recent[-1]:
            self._gaps[side].append(stamp_ns - recent[-1])
        if not recent or stamp_ns != recent[-1]:
            recent.append(stamp_ns)
        queue = self._waiting[side]
        if stamp_ns in queue:  # the same frame again (a re-publish): the newer message replaces it
            del queue[stamp_ns]
        queue[stamp_ns] = item
        pairs = self._match()
        while len(queue) > self.capacity:  # the oldest frame gives way
            oldest = min(queue)
            del queue[oldest]
            self._drop(side, oldest)
        return pairs

    def _match(self) -> list:
        colors, depths = self._waiting["color"], self._waiting["depth"]
        tolerance, pairs = self.tolerance_ns, []
        for color_stamp in sorted(colors):  # oldest first
            if not depths:
                break
            if color_stamp not in colors:
                continue
            depth_stamp = min(depths, key=lambda s: abs(s - color_stamp))
            if abs(depth_stamp - color_stamp) > tolerance:
                continue
            if min(colors, key=lambda s: abs(s - depth_stamp)) != color_stamp:
                continue  # that depth frame has a nearer colour frame: let that one take it
            pairs.append((colors.pop(color_stamp), depths.pop(depth_stamp)))
            self._paired["color"].append(color_stamp)
            self._paired["depth"].append(depth_stamp)
            self._pair_offsets.append(depth_stamp - color_stamp)
            self._outcomes.extend((True, True))
            self.paired += 1
            # everything older than the pair on either side can never pair any more
            oldest = min(color_stamp, depth_stamp)
            for side, queue in self._waiting.items():
                for stamp in [s for s in queue if s < oldest]:
                    del queue[stamp]
                    self._drop(side, stamp)
        return pairs

    def _drop(self, side: str, stamp_ns: int) -> None:
        other = "depth" if side == "color" else "color"
        candidates = list(self._recent[other])
        offset, nearest_paired = None, False
        if candidates:
            nearest = min(candidates, key=lambda s: abs(s - stamp_ns))
            offset = nearest - stamp_ns if side == "color" else stamp_ns - nearest
            nearest_paired = nearest in self._paired[other]
        self.dropped += 1
        self._unpaired.append(UnpairedFrame(side, stamp_ns, offset, self.tolerance_ns, nearest_paired,
                                            any(self._outcomes)))
        self._outcomes.append(False)

    def clear(self):
        for queue in self._waiting.values():
            queue.clear()


class StreamWatch:
    """When each of a node's input streams last delivered a message, to say which ones went silent.

    Times are seconds on any monotonic clock (the node passes time.monotonic()). A stream counts from the
    watch's start, so one that never delivered is silent once `timeout` has passed since then."""

    def __init__(self, streams, now: float):
        self._last = dict.fromkeys(streams, now)

    def seen(self, stream, now: float) -> None:
        """A message arrived on `stream` (one of the streams given at construction; KeyError otherwise)."""
        if stream not in self._last:
            raise KeyError(f"unknown stream {stream!r}; watched: {', '.join(map(str, self._last))}")
        self._last[stream] = now

    def silent(self, now: float, timeout: float) -> dict:
        """{stream: seconds since its last message} for the streams silent longer than `timeout` s, in the
        order given at construction; {} when timeout <= 0 (the watch is off)."""
        if timeout <= 0:
            return {}
        return {stream: now - last for stream, last in self._last.items() if now - last > timeout}


def unpaired_warning(unpaired: list, pairer: StampPairer, sync_tolerance: float, depth_offset: float = 0.0,
                     color_topic: str = "colour", depth_topic: str = "depth") -> str:
    """Why frames went unpaired (`unpaired`, from pairer.take_unpaired(), not empty), in one line naming the
    parameter to change: the other stream is missing; the stamps lie further apart than the tolerance
    (sync_tolerance, s; 0: automatic) - the measured offset; or partners were lost on the way - unless the
    nearest frame of the other stream lies about a frame period away and pairs with another frame, which is
    also what a constant colour-depth offset near one frame period does (every colour frame pairs with a
    neighbouring frame's depth): then that offset is named, and depth_offset (s, in force) to set."""
    last = unpaired[-1]
    other = "depth" if last.side == "color" else "colour"
    topic = depth_topic if last.side == "color" else color_topic
    sides = sorted({"colour" if frame.side == "color" else "depth" for frame in unpaired})
    text = f"{len(unpaired)} {' and '.join(sides)} frame(s) dropped unpaired ({pairer.dropped} so far): "
    if last.offset_ns is None:
        return text + f"no {other} frame has arrived on {topic} (is that stream enabled?)"
    offset, tolerance = last.offset_ns / 1e6, last.tolerance_ns / 1e6
    period = pairer.period_ns
    if sync_tolerance > 0:
        rule = f"sync_tolerance={sync_tolerance:g} s"
        advice = "set sync_tolerance above the offset, or to 0.0 to pair within half the frame period"
    else:
        rule = "sync_tolerance=0.0: half the frame period, " + (
            f"{period / 1e6:.1f} ms measured" if period else "exact stamps until the period is measured")
        advice = "set sync_tolerance (s) above the offset"
    if not last.partner_lost:
        return (text + f"depth is stamped {offset:+.1f} ms from its nearest colour frame, beyond the pairing "
                f"tolerance of {tolerance:.1f} ms ({rule}); {advice}")
    taken = ", paired with another frame" if last.nearest_paired else ""
    lost = ("their partners never arrived (lost by the best-effort transport or a busy node, or a frame came "
            f"twice): the nearest {other} frame is {offset:+.1f} ms away{taken}; other frames pair within "
            f"{tolerance:.1f} ms ({rule})")
    pairs = pairer.pair_offset_ns
    if not (last.nearest_paired and period and pairs is not None and abs(last.offset_ns) > last.tolerance_ns):
        return text + lost
    stamped = offset + depth_offset * 1e3  # as the driver stamps it
    return (text + f"depth is stamped {offset:+.1f} ms from the nearest colour frame, about one frame "
            f"period ({period / 1e6:.1f} ms) off, and pairs {pairs / 1e6:+.1f} ms from another colour frame. "
            "A constant colour-depth offset of the driver near one frame period does that: every colour "
            "frame is paired with a neighbouring frame's depth. If the driver stamps depth "
            f"{stamped:+.1f} ms from its colour frame, set depth_offset to {stamped / 1e3:.4f} s (now "
            f"{depth_offset:g} s); otherwise {lost}")
