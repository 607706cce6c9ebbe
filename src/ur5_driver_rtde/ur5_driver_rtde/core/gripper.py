"""The gripper behind a small interface, and a Robotiq 2F-85 driven through its URCap's socket.

    gripper.open(width, force, wait)   width (m) between the fingers, force (N)
    gripper.close(force, wait)
    gripper.width() -> m               measured opening
    gripper.holding() -> bool          the gripper reports an object between its fingers

Robotiq2F85 talks to the Robotiq Gripper URCap on the UR controller, which serves an ASCII protocol on
TCP port 63352: `SET <VAR> <value> ...\\n` answered `ack`, `GET <VAR>\\n` answered `<VAR> <value>`
(`<VAR> ?` while the gripper cannot be read, e.g. in an emergency stop). Variables used: ACT (activate;
0 resets and clears a fault), ATR (automatic release, 0 = off), GTO (go to the requested position), POS
(requested position 0 = open .. 255 = closed, and when read the measured one), PRE (the requested
position the gripper has taken), SPE and FOR (speed, force 0..255), STA (0 reset, 1 activating,
3 activated), OBJ (0 moving, 1 stopped opening on contact, 2 stopped closing on contact = an object is
held, 3 at the requested position). The 2F-85's stroke is 85 mm; position counts map linearly to the
opening between `open_count` (85 mm) and `closed_count` (0 mm), and force counts linearly to 20..235 N
(Robotiq's data sheet).

The handshakes follow ur_rtde's RobotiqGripper (src/robotiq_gripper.cpp: isAck, getVar, reset,
activate, move_impl, waitForMotionComplete) and the Python socket client in ur_rtde's documentation
(doc/_static/robotiq_gripper.py: RobotiqGripper._is_ack, _reset, activate, move_and_wait_for_pos):
    replies   both take one socket read as the reply and compare it to exactly `ack`: the URCap need not
              end a reply with a newline, so this client accepts a reply with or without one
    activate  only when STA is not 3: SET ACT 0 and SET ATR 0 (repeated) until ACT and STA read 0 (this
              clears a fault), then SET ACT 1 and wait until ACT reads 1 and STA 3
    move      SET POS SPE FOR GTO 1, then wait until PRE echoes the requested position (until then OBJ
              may still describe the previous move), then, to wait for the fingers, poll OBJ until not 0
Tested here against a fake URCap server only (tests/unit/ur5_driver_rtde), never on a gripper.
"""

from __future__ import annotations

import socket
import threading
import time
from typing import Protocol

URCAP_PORT = 63352
STROKE = 0.085  # m, 2F-85
FORCE_RANGE = (20.0, 235.0)  # N at FOR 0 and 255 (2F-85 data sheet)
MOVING = 0  # OBJ: the fingers move
OBJECT_HELD = 2  # OBJ: stopped while closing, on contact
RESET = 0  # STA: reset (ACT 0)
ACTIVATED = 3  # STA: activation completed
RESET_SETTLE = 0.5  # s after a reset, and
ACTIVATION_SETTLE = 1.0  # s after SET ACT 1 before polling (both ur_rtde's RobotiqGripper::activate)


class Gripper(Protocol):
    def open(self, width: float, force: float, wait: bool = True) -> None: ...

    def close(self, force: float, wait: bool = True) -> None: ...

    def width(self) -> float: ...

    def holding(self) -> bool: ...

    def disconnect(self) -> None: ...


class GripperError(RuntimeError):
    """The gripper did not answer, answered nonsense, or did not finish in time."""


class Robotiq2F85:
    """A Robotiq 2F-85 through the URCap socket (host: the UR controller's address)."""

    def __init__(self, host: str, port: int = URCAP_PORT, timeout: float = 2.0, speed: int = 255,
                 open_count: int = 0, closed_count: int = 227, motion_timeout: float = 5.0,
                 poll_period: float = 0.02, connect=socket.create_connection, sleep=time.sleep,
                 clock=time.monotonic):
        if not 0 <= open_count < closed_count <= 255:
            raise ValueError(f"need 0 <= open_count < closed_count <= 255, got {open_count}, {closed_count}")
        self.speed, self.open_count, self.closed_count = int(speed), int(open_count), int(closed_count)
        self.motion_timeout, self.poll_period = motion_timeout, poll_period
        self._sleep, self._clock = sleep, clock
        try:
            self._socket = connect((host, port), timeout=timeout)
        except OSError as error:
            raise GripperError(f"cannot reach the Robotiq URCap at {host}:{port}: {error}") from error
        self._buffer = b""
        self._requested = self.open_count
        self._exchange = threading.Lock()  # one request and its reply at a time (diagnostics read too)

    # ------------------------------------------------------------------------------------ protocol
    def _receive(self) -> None:
        try:
            chunk = self._socket.recv(1024)
        except OSError as error:
            raise GripperError(f"gripper socket: {error}") from error
        if not chunk:
            raise GripperError("gripper socket closed by the controller")
        self._buffer += chunk

    def _reply(self, complete) -> str:
        """The next reply, with or without a trailing newline: up to a newline when one has arrived, else
        what has arrived as soon as complete(text) says it is a whole reply (the reference clients take
        one socket read as the reply). A newline left over from the previous reply is skipped."""
        while True:
            self._buffer = self._buffer.lstrip(b"\r\n")
            if b"\n" in self._buffer:
                line, self._buffer = self._buffer.split(b"\n", 1)
                return line.decode("ascii", errors="replace").strip()
            text = self._buffer.decode("ascii", errors="replace").strip()
            if text and complete(text):
                self._buffer = b""
                return text
            self._receive()

    def _send(self, text: str, complete) -> str:
        with self._exchange:
            try:
                self._socket.sendall((text + "\n").encode("ascii"))
            except OSError as error:
                raise GripperError(f"gripper socket: {error}") from error
            return self._reply(complete)

    def set(self, **values: int) -> None:
        """SET VAR value ... in one line; the URCap answers `ack`."""
        command = "SET " + " ".join(f"{name} {int(value)}" for name, value in values.items())
        answer = self._send(command, lambda text: text == "ack" or not "ack".startswith(text))
        if answer != "ack":
            raise GripperError(f"{command!r} answered {answer!r}, expected 'ack'")

    def get(self, name: str) -> int:
        """GET VAR; the URCap answers `VAR value`, or `VAR ?` while the gripper cannot be read."""
        answer = self._send(f"GET {name}",
                            lambda text: len(text.split()) >= 2 or not f"{name} ".startswith(text))
        parts = answer.split()
        if len(parts) == 2 and parts[0] == name and parts[1].startswith("?"):
            raise GripperError(f"'GET {name}' answered {answer!r}: the gripper cannot be read in its "
                               f"present state (emergency stop or fault)")
        if len(parts) != 2 or parts[0] != name or not parts[1].lstrip("-").isdigit():
            raise GripperError(f"'GET {name}' answered {answer!r}")
        return int(parts[1])

    def _poll(self, done, deadline: float, failure: str) -> None:
        """Call done() every poll_period until it is true; GripperError(failure) past deadline."""
        while not done():
            if self._clock() > deadline:
                raise GripperError(failure)
            self._sleep(self.poll_period)

    # ------------------------------------------------------------------------------------ interface
    def activate(self) -> None:
        """Activate unless STA reads 3: reset first (clears a fault), then activate (on a first
        activation the fingers travel fully open and closed)."""
        if self.get("STA") == ACTIVATED:
            return
        deadline = self._clock() + 3 * self.motion_timeout

        def reset() -> bool:
            if self.get("ACT") == 0 and self.get("STA") == RESET:
                return True
            self.set(ACT=0)
            self.set(ATR=0)
            return False

        self.set(ACT=0)
        self.set(ATR=0)
        self._poll(reset, deadline, "the gripper did not reset (ACT 0, STA 0)")
        self._sleep(RESET_SETTLE)
        self.set(ACT=1)
        self._sleep(ACTIVATION_SETTLE)
        self._poll(lambda: self.get("ACT") == 1 and self.get("STA") == ACTIVATED, deadline,
                   "activation did not complete")

    def count_of_width(self, width: float) -> int:
        fraction = min(max(float(width) / STROKE, 0.0), 1.0)
        return round(self.closed_count - fraction * (self.closed_count - self.open_count))

    def width_of_count(self, count: int) -> float:
        fraction = (self.closed_count - count) / (self.closed_count - self.open_count)
        return min(max(fraction, 0.0), 1.0) * STROKE

    @staticmethod
    def force_count(force: float) -> int:
        low, high = FORCE_RANGE
        return round(min(max((float(force) - low) / (high - low), 0.0), 1.0) * 255)

    def _go(self, count: int, force: float, wait: bool) -> None:
        """Request POS count and return once the gripper has taken it (PRE reads count), or, with wait,
        once the fingers stopped (OBJ not 0). A request equal to the previous one is taken at once."""
        self._requested = count
        self.set(POS=count, SPE=self.speed, FOR=self.force_count(force), GTO=1)
        deadline = self._clock() + self.motion_timeout
        self._poll(lambda: self.get("PRE") == count, deadline,
                   f"the gripper did not take POS {count} within {self.motion_timeout:.1f} s")
        if wait:
            self._poll(lambda: self.get("OBJ") != MOVING, deadline,
                       f"fingers still moving {self.motion_timeout:.1f} s after POS {count}")

    def open(self, width: float, force: float, wait: bool = True) -> None:
        self._go(self.count_of_width(width), force, wait)

    def close(self, force: float, wait: bool = True) -> None:
        self._go(self.closed_count, force, wait)

    def width(self) -> float:
        return self.width_of_count(self.get("POS"))

    def holding(self) -> bool:
        return self._requested == self.closed_count and self.get("OBJ") == OBJECT_HELD

    def disconnect(self) -> None:
        try:
            self._socket.close()
        except OSError:
            pass
