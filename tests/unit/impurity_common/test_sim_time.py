"""Simulated time without a /clock: inputs are refused, and that is said once, naming use_sim_time."""

from impurity_common.sim_time import StoppedClockGate, stopped_clock_reason


def test_a_simulated_clock_at_zero_cannot_judge_inputs_and_says_what_to_do():
    reason = stopped_clock_reason(sim_time=True, now_ns=0)
    assert reason is not None
    assert "use_sim_time" in reason and "/clock" in reason
    assert "bag_replay -p clock:=true" in reason and "use_sim_time:=false" in reason


def test_a_running_simulated_clock_and_the_system_clock_are_used():
    assert stopped_clock_reason(sim_time=True, now_ns=1_796_382_023_021_080_823) is None
    assert stopped_clock_reason(sim_time=False, now_ns=0) is None


class FakeTime:
    def __init__(self, nanoseconds):
        self.nanoseconds = nanoseconds


class FakeClock:
    def __init__(self, sim_time, now_ns):
        self.ros_time_is_active, self.now_ns = sim_time, now_ns

    def now(self):
        return FakeTime(self.now_ns)


class FakeLogger:
    def __init__(self):
        self.warnings = []

    def warning(self, text):
        self.warnings.append(text)


class FakeNode:
    def __init__(self, sim_time, now_ns):
        self.clock, self.logger = FakeClock(sim_time, now_ns), FakeLogger()

    def get_clock(self):
        return self.clock

    def get_logger(self):
        return self.logger


def test_the_gate_refuses_every_input_while_the_clock_stands_and_says_so_once():
    node = FakeNode(sim_time=True, now_ns=0)
    gate = StoppedClockGate(node)
    assert [gate.stopped() for _ in range(5)] == [True] * 5
    assert len(node.logger.warnings) == 1
    assert node.logger.warnings[0].startswith("input dropped: use_sim_time is true and no /clock has arrived")


def test_the_gate_opens_when_a_clock_arrives():
    node = FakeNode(sim_time=True, now_ns=0)
    gate = StoppedClockGate(node)
    assert gate.stopped()
    node.clock.now_ns = 5 * 1_000_000_000
    assert not gate.stopped()


def test_the_gate_never_stops_a_node_on_the_system_clock():
    node = FakeNode(sim_time=False, now_ns=0)
    assert not StoppedClockGate(node).stopped()
    assert node.logger.warnings == []
