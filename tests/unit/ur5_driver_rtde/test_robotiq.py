"""Specification of the Robotiq 2F-85 driver against a fake of the URCap's socket server (ASCII
`SET ... -> ack`, `GET VAR -> VAR value`), in both framings a URCap may use (replies with and without a
trailing newline): activation after a reset, widths and forces to counts, waiting for the fingers only
once the gripper has taken the request (PRE), object detection, and clear errors when the server
misbehaves. No real gripper is involved."""

import socket
import threading

import pytest

from ur5_driver_rtde.core.gripper import STROKE, GripperError, Robotiq2F85

CLOSED = 227
FRAMINGS = {"newline": b"\n", "bare": b""}


class FakeUrcap:
    """One-client fake URCap and gripper. It keeps the variables and answers like the URCap, each reply
    followed by `end` (b"\\n" or nothing). A move request (SET POS ... GTO 1) is taken after
    `pre_delay` GET PRE polls: until then PRE echoes the previous request and OBJ the previous status
    (stale); then OBJ reads 0 (moving) for two polls and the fingers stop, on an object if `object_at`
    (count) lies between the open position and the request. ACT 1 activates after two STA polls; ACT 0
    resets (STA 0)."""

    def __init__(self, object_at=None, answer_set="ack", end=b"\n", pre_delay=0, status=0):
        self.values = {"ACT": int(status == 3), "GTO": 0, "STA": status, "POS": 0, "PRE": 0, "OBJ": 3,
                       "SPE": 0, "FOR": 0, "ATR": 0}
        self.lines, self.object_at, self.answer_set, self.end = [], object_at, answer_set, end
        self.pre_delay, self.pending, self.moving_polls, self.activating_polls = pre_delay, None, 0, 0
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    @property
    def fingers_stopped_on_the_last_request(self) -> bool:
        return self.pending is None and self.moving_polls == 0

    def _serve(self):
        try:
            connection, _ = self.server.accept()
        except OSError:  # closed before a client came
            return
        with connection, connection.makefile("rwb") as stream:
            for raw in stream:
                line = raw.decode().strip()
                self.lines.append(line)
                stream.write(self._answer(line).encode() + self.end)
                stream.flush()

    def _answer(self, line):
        words = line.split()
        if words[0] == "SET":
            for name, value in zip(words[1::2], words[2::2], strict=True):
                if name == "POS":
                    self.pending, self.pending_polls = int(value), self.pre_delay
                else:
                    self.values[name] = int(value)
            if "ACT" in words[1::2]:
                self.values["STA"] = 0 if self.values["ACT"] == 0 else 1
                self.activating_polls = 2
            return self.answer_set
        name = words[1]
        if name == "PRE" and self.pending is not None:
            if self.pending_polls:
                self.pending_polls -= 1
            else:
                self.values["PRE"] = self.values["POS"] = self.pending
                self.pending, self.moving_polls = None, 2
        if name == "STA" and self.values["STA"] == 1:
            self.activating_polls -= 1
            if self.activating_polls <= 0:
                self.values["STA"] = 3
        if name == "OBJ" and self.pending is None and self.moving_polls:
            self.moving_polls -= 1
            return "OBJ 0"  # still moving
        if name in ("OBJ", "POS") and self.pending is None:
            requested = self.values["PRE"]
            if self.object_at is not None and requested > self.object_at:
                return "OBJ 2" if name == "OBJ" else f"POS {self.object_at}"
            return "OBJ 3" if name == "OBJ" else f"POS {requested}"
        return f"{name} {self.values[name]}"

    def close(self):
        self.server.close()


@pytest.fixture(params=sorted(FRAMINGS))
def framing(request):
    return FRAMINGS[request.param]


@pytest.fixture
def urcap(framing):
    fake = FakeUrcap(object_at=140, end=framing)
    yield fake
    fake.close()


def connect(fake, **options):
    return Robotiq2F85("127.0.0.1", fake.port, timeout=0.5, sleep=lambda s: None, **options)


def test_replies_with_or_without_a_trailing_newline_are_understood(urcap):
    gripper = connect(urcap)
    gripper.open(0.085, force=20.0, wait=True)
    assert gripper.width() == pytest.approx(STROKE)


def test_activation_resets_the_gripper_first_then_waits_until_it_is_active(urcap):
    connect(urcap).activate()
    assert urcap.lines[:3] == ["GET STA", "SET ACT 0", "SET ATR 0"]
    activate = urcap.lines.index("SET ACT 1")
    assert "GET STA" in urcap.lines[3:activate]  # waited for the reset (STA 0) before activating
    assert urcap.lines[-1] == "GET STA" and urcap.values["STA"] == 3


def test_an_active_gripper_is_not_reset(framing):
    fake = FakeUrcap(end=framing, status=3)
    try:
        connect(fake).activate()
        assert fake.lines == ["GET STA"]
    finally:
        fake.close()


def test_a_move_is_waited_for_only_once_the_gripper_echoes_the_request(framing):
    fake = FakeUrcap(object_at=140, end=framing, pre_delay=3)  # OBJ stays at its old "3" meanwhile
    try:
        gripper = connect(fake)
        gripper.close(force=235.0, wait=True)
        assert fake.fingers_stopped_on_the_last_request
        polls = [line for line in fake.lines if line.startswith("GET")]
        assert polls[:4] == ["GET PRE"] * 4  # three stale echoes, then the request's
        assert gripper.holding()
    finally:
        fake.close()


def test_a_request_the_gripper_never_takes_is_an_error_naming_it(framing):
    fake = FakeUrcap(end=framing, pre_delay=10**6)
    try:
        clock = iter(range(10**6))
        gripper = Robotiq2F85("127.0.0.1", fake.port, timeout=0.5, sleep=lambda s: None,
                              clock=lambda: next(clock), motion_timeout=5.0)
        with pytest.raises(GripperError, match=f"did not take POS {CLOSED}"):
            gripper.close(force=20.0, wait=True)
    finally:
        fake.close()


def test_a_grasp_reports_the_object_and_its_width(urcap):
    gripper = connect(urcap)
    gripper.open(0.08, force=20.0, wait=True)
    assert f"SET POS {gripper.count_of_width(0.08)} SPE 255 FOR 0 GTO 1" in urcap.lines
    assert not gripper.holding()
    gripper.close(force=235.0, wait=True)
    assert f"SET POS {CLOSED} SPE 255 FOR 255 GTO 1" in urcap.lines
    assert urcap.fingers_stopped_on_the_last_request  # waited while the fingers moved
    assert gripper.holding()
    assert gripper.width() == pytest.approx(STROKE * (CLOSED - 140) / CLOSED)


def test_closing_on_nothing_is_not_holding(framing):
    fake = FakeUrcap(object_at=None, end=framing)
    try:
        gripper = connect(fake)
        gripper.close(force=20.0, wait=True)
        assert not gripper.holding() and gripper.width() == pytest.approx(0.0)
    finally:
        fake.close()


def test_widths_and_forces_map_to_counts_within_the_stroke(urcap):
    gripper = connect(urcap)
    assert gripper.count_of_width(STROKE) == 0 and gripper.count_of_width(0.0) == CLOSED
    assert gripper.count_of_width(0.2) == 0  # wider than the stroke: fully open
    assert gripper.width_of_count(gripper.count_of_width(0.04)) == pytest.approx(0.04, abs=STROKE / CLOSED)
    assert (Robotiq2F85.force_count(10.0), Robotiq2F85.force_count(500.0)) == (0, 255)


def test_a_refused_command_is_an_error_naming_it(framing):
    fake = FakeUrcap(answer_set="nack", end=framing)
    try:
        with pytest.raises(GripperError, match="'SET POS"):
            connect(fake).open(0.05, 20.0)
    finally:
        fake.close()


def test_an_unreachable_urcap_is_a_clear_error():
    with socket.create_server(("127.0.0.1", 0)) as unused:
        port = unused.getsockname()[1]
    with pytest.raises(GripperError, match="cannot reach the Robotiq URCap"):
        Robotiq2F85("127.0.0.1", port, timeout=0.5)


def test_a_gripper_that_cannot_be_read_is_a_clear_error(framing):
    fake = FakeUrcap(end=framing)
    fake.values["STA"] = "?"  # what the URCap answers in an emergency stop
    try:
        with pytest.raises(GripperError, match="'GET STA' answered 'STA \\?': the gripper cannot be read"):
            connect(fake).activate()
    finally:
        fake.close()
