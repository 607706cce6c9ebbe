"""The gripper behind a small interface, and a Robotiq 2F-85 driven through its URCap's socket.

    gripper.open(width, force, wait)   width (m) between the fingers, force (N)
    gripper.close(force, wait)
    gripper.width() -> m               measured opening
    gripper.holding() -> bool          the gripper reports an object between its fingers

Robotiq2F85 talks to the Robotiq Gripper URCap on the UR controller, which serves an ASCII protocol on
TCP port 63352: `SET <VAR> <value> ...\\n` answered `ack`, `GET <VAR>\\n` answered `<VAR> <value>`.
Variables used: ACT (activate), GTO (go to the requested position), POS (requested position 0 = open
.. 255 = closed, and when read the measured one), SPE and FOR (speed, force 0..255), STA (3 = activated),
OBJ (0 moving, 1 stopped opening on contact, 2 stopped closing on contact = an object is held, 3 at the
requested position). The 2F-85's stroke is 85 mm; position counts map linearly to the opening between
`open_count` (85 mm) and `closed_count` (0 mm), and force counts linearly to 20..235 N (Robotiq's data
sheet). Tested here against a fake URCap server only (tests/unit/ur5_driver_rtde), never on a gripper.
"""

from __future__ import annotations

import socket
import time
from typing import Protocol

URCAP_PORT = 63352
STROKE = 0.085  # m, 2F-85
FORCE_RANGE = (20.0, 235.0)  # N at FOR 0 and 255 (2F-85 data sheet)
OBJECT_HELD = 2  # OBJ: stopped while closing, on contact
ACTIVATED = 3  # STA: activation completed


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

    # ------------------------------------------------------------------------------------ protocol
    def _line(self) -> str:
        while b"\n" not in self._buffer:
            try:
                chunk = self._socket.recv(1024)
            except OSError as error:
                raise GripperError(f"gripper socket: {error}") from error
            if not chunk:
                raise GripperError("gripper socket closed by the controller")
            self._buffer += chunk
        line, self._buffer = self._buffer.split(b"\n", 1)
        return line.decode("ascii", errors="replace").strip()

    def _send(self, text: str) -> str:
        try:
            self._socket.sendall((text + "\n").encode("ascii"))
        except OSError as error:
            raise GripperError(f"gripper socket: {error}") from error
        return self._line()

    def set(self, **values: int) -> None:
        """SET VAR value ... in one line; the URCap answers `ack`."""
        command = "SET " + " ".join(f"{name} {int(value)}" for name, value in values.items())
        answer = self._send(command)
        if answer != "ack":
            raise GripperError(f"{command!r} answered {answer!r}, expected 'ack'")

    def get(self, name: str) -> int:
        answer = self._send(f"GET {name}")
        parts = answer.split()
        if len(parts) != 2 or parts[0] != name or not parts[1].lstrip("-").isdigit():
            raise GripperError(f"'GET {name}' answered {answer!r}")
        return int(parts[1])

    # ------------------------------------------------------------------------------------ interface
    def activate(self) -> None:
        """Activate once (the fingers travel fully open and closed on a first activation)."""
        if self.get("STA") == ACTIVATED:
            return
        self.set(ACT=1)
        deadline = self._clock() + 3 * self.motion_timeout
        while self.get("STA") != ACTIVATED:
            if self._clock() > deadline:
                raise GripperError("activation did not complete")
            self._sleep(self.poll_period)

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
        self._requested = count
        self.set(POS=count, SPE=self.speed, FOR=self.force_count(force), GTO=1)
        if not wait:
            return
        deadline = self._clock() + self.motion_timeout
        while self.get("OBJ") == 0:  # moving
            if self._clock() > deadline:
                raise GripperError(f"fingers still moving {self.motion_timeout:.1f} s after POS {count}")
            self._sleep(self.poll_period)

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
