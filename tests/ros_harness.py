"""Start the cell's executables as real processes and talk to them with rclpy, always with timeouts.

In the spirit of the UR driver's test_common.py: every wait is bounded and says what it waited for.
Processes run on the test session's isolated ROS_DOMAIN_ID (set in conftest.py).
"""

import os
import pathlib
import signal
import subprocess
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, qos_profile_sensor_data

from impurity_common.clients import RaceFreeActionClient

ROOT = pathlib.Path(__file__).resolve().parents[1]
INSTALL = ROOT / "ros2_ws" / "install"
LOG_DIR = ROOT / "ros2_ws" / "log" / "test-processes"
CELL_CONFIG = ROOT / "bringup" / "config" / "cell.yaml"
CALIBRATION = ROOT / "bringup" / "config" / "camera_calibration.yaml"  # the camera pose, read after cell.yaml


def executable_path(package: str, executable: str) -> pathlib.Path:
    """Where `ros2 run <package> <executable>` finds it (setup.cfg script_dir)."""
    path = INSTALL / package / "lib" / package / executable
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist: run `make setup` (colcon build) first")
    return path


def ros_args(parameters: dict | None = None, params_file: str | os.PathLike | None = None,
             remappings: dict | None = None, node_name: str | None = None) -> list[str]:
    """`--ros-args` for an executable: params_file, then the `-p` parameters, then remappings. The cell's
    bringup/config/cell.yaml is followed by the camera calibration file, as the launchers pass them
    (impurity_bringup.cell_nodes), so that the camera pose comes from where the cell reads it."""
    args = ["--ros-args"]
    if params_file is not None:
        args += ["--params-file", str(params_file)]
        if pathlib.Path(params_file).resolve() == CELL_CONFIG:
            args += ["--params-file", str(CALIBRATION)]
    for name, value in (parameters or {}).items():
        if isinstance(value, bool):
            value = "true" if value else "false"
        elif isinstance(value, (list, tuple)):
            value = "[" + ",".join(str(v) for v in value) + "]"
        args += ["-p", f"{name}:={value}"]
    for src, dst in (remappings or {}).items():
        args += ["-r", f"{src}:={dst}"]
    if node_name:
        args += ["-r", f"__node:={node_name}"]
    return args if len(args) > 1 else []


class NodeProcess:
    """One executable in its own process; output goes to a log file read back on failure."""

    def __init__(self, package: str, executable: str, args: list[str] | None = None,
                 env: dict | None = None):
        self.name = f"{package}/{executable}"
        LOG_DIR.mkdir(parents=True, exist_ok=True)
        self.log_path = LOG_DIR / f"{executable}-{os.getpid()}-{time.monotonic_ns()}.log"
        self._log = open(self.log_path, "w")
        full_env = dict(os.environ)
        full_env.update(env or {})
        full_env.setdefault("PYTHONUNBUFFERED", "1")
        self.process = subprocess.Popen(
            [str(executable_path(package, executable)), *(args or [])],
            stdout=self._log, stderr=subprocess.STDOUT, env=full_env, start_new_session=True)

    @property
    def alive(self) -> bool:
        return self.process.poll() is None

    def output(self) -> str:
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors="replace")

    def send_signal(self, sig: int) -> None:
        if self.alive:
            os.killpg(self.process.pid, sig)

    def stop(self, timeout: float = 10.0) -> int:
        """SIGINT (what Ctrl-C sends), then SIGTERM, then SIGKILL; returns the exit code."""
        for sig, wait in ((signal.SIGINT, timeout), (signal.SIGTERM, 3.0), (signal.SIGKILL, 3.0)):
            if not self.alive:
                break
            try:
                os.killpg(self.process.pid, sig)
            except ProcessLookupError:
                break
            try:
                self.process.wait(wait)
            except subprocess.TimeoutExpired:
                continue
        self._log.close()
        return self.process.returncode


class WaitTimeout(AssertionError):
    """A bounded wait ran out; the message says what was awaited."""


class ProcessDied(WaitTimeout):
    """A process the wait depended on died; the message has its last output."""


def spin_until(node: Node, predicate, timeout: float, what: str, processes=()) -> None:
    """Spin `node` until predicate() is true; fail with `what` (and dead processes' output)."""
    deadline = time.monotonic() + timeout
    while not predicate():
        for proc in processes:
            if not proc.alive:
                raise ProcessDied(f"{proc.name} died while waiting for {what}:\n{proc.output()[-3000:]}")
        if time.monotonic() > deadline:
            raise WaitTimeout(f"timed out after {timeout:.0f} s waiting for {what}")
        rclpy.spin_once(node, timeout_sec=0.05)


_clients: dict = {}  # (node, service type, name) -> client, kept so its endpoints stay matched


def wait_for_service(node: Node, srv_type, name: str, timeout: float = 30.0, processes=()):
    """The node's client of `name` (created once, then reused), once the service is ready."""
    key = (node, srv_type, name)
    if key not in _clients:
        _clients[key] = node.create_client(srv_type, name)
    client = _clients[key]
    spin_until(node, client.service_is_ready, timeout, f"service {name}", processes)
    return client


def call_service(node: Node, srv_type, name: str, request, timeout: float = 30.0, processes=(),
                 resend_after: float | None = None):
    """One call, bounded by `timeout`. A server can take a request before it has matched the client's
    response reader and then drops the answer (Fast DDS: "failed to send response (timeout)"), most
    likely on a client's first call on a loaded machine: clients are reused, and an idempotent request
    (a refusal, a query) may pass `resend_after` seconds to be sent again while unanswered."""
    client = wait_for_service(node, srv_type, name, timeout, processes)
    deadline = time.monotonic() + timeout
    while True:
        future = client.call_async(request)
        wait = timeout if resend_after is None else min(resend_after, max(deadline - time.monotonic(), 0.1))
        try:
            spin_until(node, future.done, wait, f"response from {name}", processes)
            return future.result()
        except WaitTimeout:
            client.remove_pending_request(future)
            if resend_after is None or time.monotonic() >= deadline:
                raise WaitTimeout(f"timed out after {timeout:.0f} s waiting for response from {name}") \
                    from None


class ActionHelper:
    """Send goals to one action server and collect feedback, every step bounded by a timeout."""

    def __init__(self, node: Node, action_type, name: str, timeout: float = 30.0, processes=()):
        self.node, self.name, self.processes = node, name, processes
        self.client = RaceFreeActionClient(node, action_type, name)
        spin_until(node, self.client.server_is_ready, timeout, f"action server {name}", processes)
        self.feedback = []

    def send_goal(self, goal, timeout: float = 30.0):
        """Returns the goal handle (check .accepted); raises WaitTimeout when the server says nothing about
        the goal within `timeout` s. A goal whose response is lost below rclpy is followed without it
        (RaceFreeActionClient.send_goal_following, as impurity_bringup.episode_client does): never sent
        twice."""
        def wait(predicate, seconds: float) -> bool:
            try:
                spin_until(self.node, predicate, seconds, f"goal response from {self.name}", self.processes)
                return True
            except ProcessDied:
                raise
            except WaitTimeout:
                return False

        def collect(feedback) -> None:
            self.feedback.append(feedback.feedback)

        handle = self.client.send_goal_following(goal, wait, feedback_callback=collect,
                                                 answer_timeout=timeout)
        if handle is None:
            raise WaitTimeout(f"timed out after {timeout:.0f} s waiting for goal response from {self.name}")
        return handle

    def get_result(self, goal_handle, timeout: float = 60.0):
        future = goal_handle.get_result_async()
        spin_until(self.node, future.done, timeout, f"result from {self.name}", self.processes)
        return future.result()

    def run(self, goal, timeout: float = 60.0):
        handle = self.send_goal(goal, timeout=min(timeout, 30.0))
        if not handle.accepted:
            return handle, None
        return handle, self.get_result(handle, timeout)

    def cancel(self, goal_handle, timeout: float = 30.0):
        future = goal_handle.cancel_goal_async()
        spin_until(self.node, future.done, timeout, f"cancel response from {self.name}", self.processes)
        return future.result()

    def destroy(self):
        self.client.destroy()


class TopicRecorder:
    """Subscribe to a topic and keep what arrives; wait for messages with a timeout."""

    def __init__(self, node: Node, msg_type, topic: str, qos: QoSProfile | int = 10):
        self.node, self.topic, self.messages = node, topic, []
        self.subscription = node.create_subscription(msg_type, topic, self.messages.append, qos)

    def wait_for(self, count: int = 1, timeout: float = 30.0, predicate=None, processes=()):
        """Wait until `count` messages (matching predicate, if given) arrived; returns them."""
        def matching():
            return [m for m in self.messages if predicate is None or predicate(m)]
        spin_until(self.node, lambda: len(matching()) >= count, timeout,
                   f"{count} message(s) on {self.topic}", processes)
        return matching()

    def destroy(self):
        self.node.destroy_subscription(self.subscription)


def activate(node: Node, target: str, timeout: float = 60.0, processes=()) -> None:
    """Configure, then activate, the lifecycle node `target` (e.g. "/ur5_driver") as the launchers do
    (impurity_bringup.lifecycle.bring_to_active; LifecycleFailed names a failed transition and its reason)."""
    from impurity_bringup.lifecycle import bring_to_active

    def dead() -> bool:
        for proc in processes:
            if not proc.alive:
                raise ProcessDied(f"{proc.name} died while being activated:\n{proc.output()[-3000:]}")
        return False

    bring_to_active(node, target, timeout, should_stop=dead)


def wait_for_subscribers(node: Node, publisher, count: int = 1, timeout: float = 30.0, processes=()):
    spin_until(node, lambda: publisher.get_subscription_count() >= count, timeout,
               f"{count} subscriber(s) on {publisher.topic_name}", processes)


def publish_until_answered(node: Node, publisher, make_message, recorder: TopicRecorder,
                           timeout: float = 60.0, period: float = 2.0, processes=()):
    """Republish make_message() until `recorder` hears an answer: a matched publisher does not mean
    the subscriber has matched it back, so the first messages after discovery may be dropped."""
    wait_for_subscribers(node, publisher, timeout=timeout, processes=processes)
    deadline = time.monotonic() + timeout
    heard = len(recorder.messages)
    while len(recorder.messages) == heard:
        publisher.publish(make_message())
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise WaitTimeout(f"timed out after {timeout:.0f} s waiting for an answer on {recorder.topic}")
        try:
            recorder.wait_for(heard + 1, min(period, remaining), processes=processes)
        except WaitTimeout:
            continue
    return recorder.messages[heard]


SENSOR_QOS = qos_profile_sensor_data
