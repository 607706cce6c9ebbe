"""The shared /diagnostics publisher: a node's Status as a DiagnosticStatus, the rate and latency meters
the nodes measure with, and a check that fails reported as ERROR instead of raised."""

import pytest
from diagnostic_msgs.msg import DiagnosticStatus

from impurity_common import diagnostics
from impurity_common.diagnostics import ERROR, OK, WARN, LatencyMeter, RateMeter, Status, values_of


class FakeClock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_a_status_becomes_a_diagnostic_status_with_its_values_as_strings():
    status = diagnostics.status_message("ur5_driver", Status(WARN, "protective stop", {
        "safety mode": "3 PROTECTIVE_STOP", "frame rate (Hz)": 14.98765, "holding": False,
        "pairs dropped": 2}),
        hardware_id="192.168.1.10")
    assert status.level == DiagnosticStatus.WARN and status.name == "ur5_driver"
    assert status.message == "protective stop" and status.hardware_id == "192.168.1.10"
    assert values_of(status) == {"safety mode": "3 PROTECTIVE_STOP", "frame rate (Hz)": "14.99",
                                 "holding": "false", "pairs dropped": "2"}


def test_levels_are_the_message_constants():
    assert [bytes([level]) for level in (OK, WARN, ERROR, diagnostics.STALE)] == [
        DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR, DiagnosticStatus.STALE]


def test_the_rate_is_events_per_second_over_the_window():
    clock = FakeClock()
    meter = RateMeter(window=10.0, clock=clock)
    assert meter.rate() == 0.0
    for _ in range(31):  # 15 Hz for 2 s
        meter.tick()
        clock.now += 1 / 15
    assert meter.rate() == pytest.approx(15.0)
    clock.now += 30.0  # the stream stopped: nothing in the window
    assert meter.rate() == 0.0 and meter.count == 31


def test_latency_is_the_last_the_mean_and_the_largest_of_the_window():
    clock = FakeClock()
    meter = LatencyMeter(window=10.0, clock=clock)
    assert meter.last is None and meter.mean() is None and meter.largest() is None
    for seconds in (0.2, 0.4, 0.3):
        meter.add(seconds)
        clock.now += 1.0
    assert (meter.last, meter.mean(), meter.largest()) == (0.3, pytest.approx(0.3), 0.4)
    clock.now += 20.0
    assert meter.mean() is None and meter.last == 0.3 and meter.count == 3


def test_a_node_publishes_its_status_and_a_failing_check_is_an_error(rcl_context):
    import rclpy

    from impurity_common import names

    node = rclpy.create_node("diagnosed", context=rcl_context)
    listener = rclpy.create_node("diagnostics_listener", context=rcl_context)
    try:
        received = []
        listener.create_subscription(diagnostics.DiagnosticArray, names.DIAGNOSTICS_TOPIC, received.append,
                                     10)
        checks = iter([Status(OK, "ready", {"frames": 3})])

        def check():
            return next(checks)  # the second call raises StopIteration

        published = diagnostics.Diagnostics(node, check, period=0.05)
        assert published.current() == Status(OK, "ready", {"frames": 3})
        failed = published.current()
        assert failed.level == ERROR and failed.message.startswith("diagnostics check failed: StopIteration")
        executor = rclpy.executors.SingleThreadedExecutor(context=rcl_context)
        executor.add_node(node)
        executor.add_node(listener)
        for _ in range(400):
            if any(s.name == "diagnosed" for msg in received for s in msg.status):
                break
            executor.spin_once(timeout_sec=0.05)
        statuses = [s for msg in received for s in msg.status if s.name == "diagnosed"]
        assert statuses and statuses[0].level == DiagnosticStatus.ERROR
        executor.shutdown()
    finally:
        node.destroy_node()
        listener.destroy_node()
