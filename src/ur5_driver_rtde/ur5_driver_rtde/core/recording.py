"""Dry run: stand-ins for ur-rtde's interfaces that record every command instead of sending it.

`DryRunRobot` offers the three objects the driver would get from ur-rtde (`control` like
rtde_control.RTDEControlInterface, `receive` like rtde_receive.RTDEReceiveInterface) and a gripper
(`DryRunGripper`), all writing to one `CommandLog`. The driver's code runs unchanged on them, so the log
is exactly the sequence of ur-rtde calls (name and arguments) a real cell would receive. The simulated
robot arrives at every commanded pose at once and keeps its connection until told otherwise
(`drop_after`: lose the connection at the n-th motion command, to test recovery); a guarded move meets
an object only when `contact_height` says where (TCP height in base_link, m): the contact detection started
after the moveL finds the arm there and reports it (as ur-rtde's control script, which stops the move and
retracts to the first contact, leaves the arm at the object). The controller stays in safety mode NORMAL
(1) and robot mode RUNNING (7) unless a test sets the state's `safety_mode` / `robot_mode`, and reports
PolyScope `polyscope` (DRY_RUN_POLYSCOPE: an e-Series, with contact detection).

Each record (one JSON object per line of the log file):
    {"seq": 3, "interface": "rtde_control", "command": "moveL",
     "args": {"pose": [...], "speed": 0.5, "acceleration": 1.2, "asynchronous": true},
     "goal": 1, "step": 2, "phase": "descend", "step_kind": "guarded"}
`goal`, `step`, `phase`, `step_kind` are the executor's context when the command was sent.
"""

from __future__ import annotations

import json
import math
import threading
from collections.abc import Callable

import numpy as np

from impurity_common import cell
from ur5_motion import ur5_kinematics

from .poses import tcp_from_ur_pose, ur_tool0_pose

MOTION_COMMANDS = ("moveL", "moveJ", "moveJ_IK")
DRY_RUN_POLYSCOPE = "5.11.1"  # the dry run's controller version (as DashboardClient.polyscopeVersion)


class CommandLog:
    """Ordered record of the commands a backend sent (or would send); optional JSONL file and echo."""

    def __init__(self, path: str | None = None, echo: Callable[[str], None] | None = None):
        self.records: list[dict] = []
        self.context: dict = {}
        self.echo = echo  # called with a one-line summary of each record (e.g. a ROS logger)
        self._lock = threading.Lock()
        self._file = open(path, "a", encoding="utf-8") if path else None  # appended to, kept open

    def record(self, interface: str, command: str, **args) -> dict:
        with self._lock:
            entry = {"seq": len(self.records), "interface": interface, "command": command,
                     "args": _plain(args), **self.context}
            self.records.append(entry)
            line = json.dumps(entry, sort_keys=True)
            if self._file is not None:
                self._file.write(line + "\n")
                self._file.flush()
        if self.echo is not None:
            self.echo(f"dry run: {interface}.{command}({_short(args)})")
        return entry

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def _plain(value):
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


def _short(args: dict) -> str:
    def fmt(v):
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(fmt(x) for x in v) + "]"
        return f"{v:.4f}" if isinstance(v, float) else repr(v)
    return ", ".join(f"{k}={fmt(v)}" for k, v in args.items())


class ConnectionDropped(RuntimeError):
    """What the dry-run robot raises once its simulated connection is gone (ur-rtde raises RuntimeError)."""


class _DryRunState:
    """The simulated controller: where the arm is, and whether it still answers."""

    def __init__(self, drop_after: int | None, contact_height: float | None = None,
                 flange_to_tcp: float = cell.FLANGE_TO_TCP):
        self.contact_height = contact_height  # m, TCP height (base_link) where guarded moves meet an object
        self.flange_to_tcp = flange_to_tcp  # m, the driver's TCP along tool0 z (for contact_height)
        self.detecting = False  # between startContactDetection and stopContactDetection
        self.touched = False
        self.last_linear = False  # the last motion command was moveL (what contact detection watches)
        self.safety_mode, self.robot_mode = 1, 7  # NORMAL, RUNNING (core/arm.py: SAFETY_MODES, ROBOT_MODES)
        self.q = np.array(ur5_kinematics.HOME_JOINTS, dtype=float)
        self.pose = self._pose_of(self.q)
        self.connected = True
        self.motions = 0
        self.drop_after = drop_after
        self.progress = -1  # getAsyncOperationProgress: toggles -1/-2 at each finished async operation

    @staticmethod
    def _pose_of(q) -> list:
        """tool0's pose at q (through the kinematic model's TCP, which sits cell.FLANGE_TO_TCP below)."""
        tcp = ur5_kinematics.tcp_pose(q)
        return ur_tool0_pose(tcp[:3, 3], math.atan2(tcp[1, 0], tcp[0, 0]), cell.FLANGE_TO_TCP)

    def motion(self, pose=None, q=None, linear: bool = False) -> None:
        """A motion command arrives: lose the connection if scripted, else be there at once."""
        self.check()
        self.motions += 1
        if self.drop_after is not None and self.motions > self.drop_after:
            self.connected = False
            raise ConnectionDropped("dry run: connection to the controller dropped (scripted)")
        self.last_linear = linear
        if q is not None:
            self.q = np.asarray(q, dtype=float)
            self.pose = self._pose_of(self.q)
        else:
            self._arrive(pose)
        self.progress = -2 if self.progress == -1 else -1

    def _arrive(self, pose) -> None:
        position, yaw = tcp_from_ur_pose(pose, cell.FLANGE_TO_TCP)  # the model's TCP, for its IK
        try:
            self.q = ur5_kinematics.ik(position, yaw, self.q)
        except ur5_kinematics.IKError:
            pass  # joint states keep the last solution; the pose is what was commanded
        self.pose = list(pose)

    def start_contact_detection(self) -> None:
        """Contact detection starts while the last moveL runs: it stops at contact_height when its
        target lies below."""
        self.check()
        self.detecting, self.touched = True, False
        if not self.last_linear or self.contact_height is None:
            return
        tcp, yaw = tcp_from_ur_pose(self.pose, self.flange_to_tcp)
        if tcp[2] < self.contact_height:
            self._arrive(ur_tool0_pose((tcp[0], tcp[1], self.contact_height), yaw, self.flange_to_tcp))
            self.touched = True  # stopped on the object

    def check(self) -> None:
        if not self.connected:
            raise ConnectionDropped("dry run: not connected")


class DryRunControl:
    """Records what rtde_control.RTDEControlInterface would be asked to do (queries are not recorded)."""

    def __init__(self, log: CommandLog, state: _DryRunState):
        self._log, self._state = log, state

    def _send(self, command, **args):
        self._state.check()
        self._log.record("rtde_control", command, **args)
        return True

    def setTcp(self, tcp_offset):  # noqa: N802 (ur-rtde's names)
        return self._send("setTcp", tcp_offset=list(tcp_offset))

    def moveL(self, pose, speed=0.25, acceleration=1.2, asynchronous=False):  # noqa: N802
        self._log.record("rtde_control", "moveL", pose=list(pose), speed=speed, acceleration=acceleration,
                         asynchronous=asynchronous)
        self._state.motion(pose=pose, linear=True)
        return True

    def moveJ(self, q, speed=1.05, acceleration=1.4, asynchronous=False):  # noqa: N802
        self._log.record("rtde_control", "moveJ", q=list(q), speed=speed, acceleration=acceleration,
                         asynchronous=asynchronous)
        self._state.motion(q=q)
        return True

    def moveJ_IK(self, pose, speed=1.05, acceleration=1.4, asynchronous=False):  # noqa: N802
        self._log.record("rtde_control", "moveJ_IK", pose=list(pose), speed=speed, acceleration=acceleration,
                         asynchronous=asynchronous)
        self._state.motion(pose=pose)
        return True

    def stopL(self, a=10.0, asynchronous=False):  # noqa: N802
        # Recorded even without a connection: the driver's attempt to stop the arm is what matters.
        self._log.record("rtde_control", "stopL", a=a, asynchronous=asynchronous)

    def stopJ(self, a=2.0, asynchronous=False):  # noqa: N802
        self._log.record("rtde_control", "stopJ", a=a, asynchronous=asynchronous)

    def startContactDetection(self, direction):  # noqa: N802
        self._state.start_contact_detection()
        return self._send("startContactDetection", direction=list(direction))

    def stopContactDetection(self):  # noqa: N802
        self._state.detecting = False
        return self._send("stopContactDetection")

    def readContactDetection(self):  # noqa: N802
        self._state.check()
        return self._state.touched

    def getAsyncOperationProgress(self):  # noqa: N802
        self._state.check()
        return self._state.progress

    def isConnected(self):  # noqa: N802
        return self._state.connected

    def stopScript(self):  # noqa: N802
        self._log.record("rtde_control", "stopScript")

    def disconnect(self):
        self._log.record("rtde_control", "disconnect")


class DryRunReceive:
    """Answers like rtde_receive.RTDEReceiveInterface from the simulated controller's state."""

    def __init__(self, state: _DryRunState):
        self._state = state

    def getActualQ(self):  # noqa: N802
        self._state.check()
        return [float(v) for v in self._state.q]

    def getActualTCPPose(self):  # noqa: N802
        self._state.check()
        return list(self._state.pose)

    def getActualTCPForce(self):  # noqa: N802
        self._state.check()
        return [0.0] * 6

    def getSafetyMode(self):  # noqa: N802
        self._state.check()
        return self._state.safety_mode

    def getRobotMode(self):  # noqa: N802
        self._state.check()
        return self._state.robot_mode

    def isConnected(self):  # noqa: N802
        return self._state.connected

    def disconnect(self):
        pass


class DryRunGripper:
    """Records gripper commands; after closing it reports `held_width` (m) between the fingers: > 0
    simulates an object held, 0 fingers closed on nothing."""

    def __init__(self, log: CommandLog, held_width: float = 0.03, max_width: float = 0.085):
        self._log, self._held_width, self.max_width = log, float(held_width), float(max_width)
        self._width = self.max_width
        self._closed = False

    def open(self, width: float, force: float, wait: bool = True) -> None:
        self._log.record("gripper", "open", width=float(width), force=float(force), wait=bool(wait))
        self._width, self._closed = min(float(width), self.max_width), False

    def close(self, force: float, wait: bool = True) -> None:
        self._log.record("gripper", "close", force=float(force), wait=bool(wait))
        self._width, self._closed = self._held_width, True

    def width(self) -> float:
        return self._width

    def holding(self) -> bool:
        return self._closed and self._width > 0.0

    def disconnect(self) -> None:
        pass


class DryRunRobot:
    """control + receive (ur-rtde stand-ins) and a gripper sharing one CommandLog and one simulated
    controller. drop_after: the connection drops at motion command number drop_after + 1 (None: never);
    contact_height: TCP height (m, base_link) where guarded moves meet an object (None: never);
    polyscope: the controller's PolyScope version, as the dashboard server reports it."""

    def __init__(self, log: CommandLog, drop_after: int | None = None, held_width: float = 0.03,
                 contact_height: float | None = None, flange_to_tcp: float = cell.FLANGE_TO_TCP,
                 polyscope: str = DRY_RUN_POLYSCOPE):
        self.log = log
        self.polyscope = polyscope
        self.state = _DryRunState(drop_after, contact_height, flange_to_tcp)
        self.control = DryRunControl(log, self.state)
        self.receive = DryRunReceive(self.state)
        self.gripper = DryRunGripper(log, held_width)
