"""Specification of the Robotiq 2F-85 driver against a fake of the URCap's socket server (ASCII
`SET ... -> ack`, `GET VAR -> VAR value`): activation, widths and forces to counts, waiting for the
fingers, object detection, and clear errors when the server misbehaves. No real gripper is involved."""

import socket
import threading

import pytest

from ur5_driver_rtde.core.gripper import STROKE, GripperError, Robotiq2F85

CLOSED = 227


class FakeUrcap:
    """One-client fake URCap: keeps the variables, answers like the URCap, closes on an object if
    `object_at` (count) lies between the open position and the requested one."""

    def __init__(self, object_at=None, answer_set="ack"):
        self.values = {"ACT": 0, "GTO": 0, "STA": 0, "POS": 0, "OBJ": 3, "SPE": 0, "FOR": 0}
        self.lines, self.object_at, self.answer_set = [], object_at, answer_set
        self.moving_polls = 0
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        try:
            connection, _ = self.server.accept()
        except OSError:  # closed before a client came
            return
        with connection, connection.makefile("rwb") as stream:
            for raw in stream:
                line = raw.decode().strip()
                self.lines.append(line)
                stream.write((self._answer(line) + "\n").encode())
                stream.flush()

    def _answer(self, line):
        words = line.split()
        if words[0] == "SET":
            for name, value in zip(words[1::2], words[2::2], strict=True):
                self.values[name] = int(value)
            if self.values["ACT"] == 1:
                self.values["STA"] = 3
            if "POS" in words:
                self.moving_polls = 2
            return self.answer_set
        name = words[1]
        if name == "OBJ" and self.moving_polls:
            self.moving_polls -= 1
            return "OBJ 0"  # still moving
        if name in ("OBJ", "POS"):
            requested = self.values["POS"]
            if self.object_at is not None and requested > self.object_at:
                return "OBJ 2" if name == "OBJ" else f"POS {self.object_at}"
            return "OBJ 3" if name == "OBJ" else f"POS {requested}"
        return f"{name} {self.values[name]}"

    def close(self):
        self.server.close()


@pytest.fixture
def urcap():
    fake = FakeUrcap(object_at=140)
    yield fake
    fake.close()


def connect(fake, **options):
    return Robotiq2F85("127.0.0.1", fake.port, sleep=lambda s: None, **options)


def test_activation_then_grasp_reports_the_object_and_its_width(urcap):
    gripper = connect(urcap)
    gripper.activate()
    assert urcap.lines[:2] == ["GET STA", "SET ACT 1"]
    gripper.open(0.08, force=20.0, wait=True)
    assert f"SET POS {gripper.count_of_width(0.08)} SPE 255 FOR 0 GTO 1" in urcap.lines
    assert not gripper.holding()
    gripper.close(force=235.0, wait=True)
    assert f"SET POS {CLOSED} SPE 255 FOR 255 GTO 1" in urcap.lines
    assert urcap.lines.count("GET OBJ") >= 3  # waited while the fingers moved
    assert gripper.holding()
    assert gripper.width() == pytest.approx(STROKE * (CLOSED - 140) / CLOSED)


def test_closing_on_nothing_is_not_holding():
    fake = FakeUrcap(object_at=None)
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


def test_a_refused_command_is_an_error_naming_it():
    fake = FakeUrcap(answer_set="nack")
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
