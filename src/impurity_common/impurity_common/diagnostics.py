"""Every node's status on /diagnostics, once a second: one place for the concept, plain rclpy.

    Diagnostics(node, check)   publishes diagnostic_msgs/DiagnosticArray on names.DIAGNOSTICS_TOPIC with one
                               DiagnosticStatus: name the node's name, level, message and key/value pairs
                               from check() -> Status, every PERIOD s of the steady clock (it keeps
                               reporting while a simulated /clock stands still)

The convention is diagnostic_updater's (not in the pip environment): 1 Hz, OK / WARN / ERROR / STALE, the
values as strings. See them with `ros2 topic echo /diagnostics` or rqt_runtime_monitor
(docs/real_cell.md, "Lifecycle and diagnostics").

RateMeter (events per second over a window) and LatencyMeter (the last, mean and largest duration over a
window) are what nodes measure with; they take a clock and hold no ROS object.
"""

from __future__ import annotations

import collections
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType

from impurity_common import names

OK, WARN, ERROR, STALE = 0, 1, 2, 3  # DiagnosticStatus levels
LEVEL_NAMES = {OK: "OK", WARN: "WARN", ERROR: "ERROR", STALE: "STALE"}
PERIOD = 1.0  # s between two reports (diagnostic_updater's default rate)
WINDOW = 10.0  # s of events a RateMeter or a LatencyMeter looks back over


@dataclass(frozen=True)
class Status:
    """What a node reports: a level (OK, WARN, ERROR, STALE), one line, and named values."""

    level: int
    message: str
    values: dict = field(default_factory=dict)


def format_value(value) -> str:
    """A value as a DiagnosticStatus carries it: floats with 4 significant digits, booleans true/false."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def status_message(name: str, status: Status, hardware_id: str = "") -> DiagnosticStatus:
    """The DiagnosticStatus of `status` under `name`."""
    return DiagnosticStatus(level=bytes([status.level]), name=name, message=status.message,
                            hardware_id=hardware_id,
                            values=[KeyValue(key=str(key), value=format_value(value))
                                    for key, value in status.values.items()])


def values_of(status: DiagnosticStatus) -> dict[str, str]:
    """{key: value} of a received DiagnosticStatus."""
    return {pair.key: pair.value for pair in status.values}


class RateMeter:
    """Events per second over the last `window` s (clock: seconds, monotonic)."""

    def __init__(self, window: float = WINDOW, clock: Callable[[], float] = time.monotonic):
        self.window, self._clock = window, clock
        self._times: collections.deque = collections.deque()
        self.count = 0  # every event since the start

    def tick(self) -> None:
        self.count += 1
        self._times.append(self._clock())

    def rate(self) -> float:
        """Events per second: the events of the window over the time they span (0 with fewer than two)."""
        now = self._clock()
        while self._times and now - self._times[0] > self.window:
            self._times.popleft()
        if len(self._times) < 2:
            return 0.0
        return (len(self._times) - 1) / max(self._times[-1] - self._times[0], 1e-9)


class LatencyMeter:
    """Durations (s) of the last `window` s: the last one, the mean and the largest."""

    def __init__(self, window: float = WINDOW, clock: Callable[[], float] = time.monotonic):
        self.window, self._clock = window, clock
        self._samples: collections.deque = collections.deque()
        self.last: float | None = None
        self.count = 0

    def add(self, seconds: float) -> None:
        self.last = float(seconds)
        self.count += 1
        self._samples.append((self._clock(), self.last))

    def _recent(self) -> list[float]:
        now = self._clock()
        while self._samples and now - self._samples[0][0] > self.window:
            self._samples.popleft()
        return [seconds for _, seconds in self._samples]

    def mean(self) -> float | None:
        recent = self._recent()
        return sum(recent) / len(recent) if recent else None

    def largest(self) -> float | None:
        recent = self._recent()
        return max(recent) if recent else None


class Diagnostics:
    """Publishes check()'s Status on /diagnostics every `period` s of the steady clock; a check that
    raises is reported as ERROR with the exception, never raised into the executor."""

    def __init__(self, node, check: Callable[[], Status], hardware_id: str = "", period: float = PERIOD,
                 callback_group=None):
        self._node, self.check, self.hardware_id = node, check, hardware_id
        self._publisher = node.create_publisher(DiagnosticArray, names.DIAGNOSTICS_TOPIC, 10)
        self._timer = node.create_timer(period, self.publish, callback_group=callback_group,
                                        clock=Clock(clock_type=ClockType.STEADY_TIME))

    def current(self) -> Status:
        try:
            return self.check()
        except Exception as error:  # noqa: BLE001 - a report of the failure is what diagnostics are for
            return Status(ERROR, f"diagnostics check failed: {type(error).__name__}: {error}")

    def publish(self) -> None:
        if not self._node.context.ok():
            return
        status = status_message(self._node.get_name(), self.current(), self.hardware_id)
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self._node.get_clock().now().to_msg()
        self._publisher.publish(msg)
