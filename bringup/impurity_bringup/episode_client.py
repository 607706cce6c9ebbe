"""Command-line client: start a picking episode, print one line per action, then the paper's metrics.

    episode_client --scenario random --seed 7     (or python -m impurity_bringup.episode_client ...)

Equivalent on a ROS install:
  ros2 action send_goal --feedback /episode/run impurity_interfaces/action/RunEpisode \
      "{scenario: random, seed: 7}"

The request is checked here first, with the episode node's own check (core.episode.validate_request):
a bad one is refused with its reason before anything is sent. --start-only uses /episode/start (answers
with the reason of a refusal); --stop ends the running episode however it was started (/episode/stop).
A goal of /episode/run rejected for the cell's state (an action's rejection carries no reason) is
explained by the node's /episode/status.
"""

import argparse
import contextlib
import dataclasses
import os
import pathlib
import signal
import subprocess
import sys
import time

import rclpy
from rclpy.signals import SignalHandlerOptions
from std_srvs.srv import Trigger

from impurity_bringup.cell_nodes import namespace_of
from impurity_common.clients import RaceFreeActionClient
from impurity_common.enums import EPISODE_SCENARIOS, PrimitiveKind, Scenario
from impurity_common.names import (
    EPISODE_STATUS_SERVICE,
    RUN_EPISODE_ACTION,
    START_EPISODE_SERVICE,
    STOP_EPISODE_SERVICE,
    absolute,
)
from impurity_interfaces.action import RunEpisode
from impurity_interfaces.srv import StartEpisode
from impurity_policy.core.episode import (
    COUNTED_BY_NOTHING,
    FIELD_RANGES,
    TERMINATION_CANCELED,
    EpisodeRequest,
    describe_request,
    is_failure,
    validate_request,
)

CANCEL_TIMEOUT = 30.0  # s for the episode node to confirm a cancel (the arm stops and leaves upwards)
OPTION_OF_FIELD = {"num_targets": "--targets", "num_objects": "--objects", "max_actions": "--max-actions",
                   "scene_file": "--scene-file"}
STOP_TIMEOUT = 45.0  # s for /episode/stop's answer (the node answers once the episode ended, within 30 s)


@contextlib.contextmanager
def running_cell(out: pathlib.Path, config: pathlib.Path | None = None):
    """The whole node graph (impurity_bringup.launch_cell, with `config` or the installed cell.yaml) for the
    duration of a `with`: episode records in `out`, node logs in out/logs; stopped with SIGINT (SIGKILL
    after 30 s) on the way out."""
    out.mkdir(parents=True, exist_ok=True)
    extra = ["--config", str(config)] if config is not None else []
    launcher = subprocess.Popen(
        [sys.executable, "-m", "impurity_bringup.launch_cell", "--quiet", "--log-dir", str(out / "logs"),
         "--record-dir", str(out), *extra], start_new_session=True)
    try:
        yield launcher
    finally:
        if launcher.poll() is None:
            os.killpg(launcher.pid, signal.SIGINT)
            try:
                launcher.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(launcher.pid, signal.SIGKILL)


def format_step(step) -> str:
    p = step.primitive
    outcome = "target picked" if step.target_grasped else ("ok" if step.success else "failed")
    left = (f"targets left {step.targets_remaining}" if step.targets_remaining >= 0  # counted by truth
            else step.verdict)  # counted by perception: the grasp's verdict ("" for a push)
    return (f"step {step.step:2d}  {step.attention_mode:<15s} {kind_label(p.kind):<5s} "
            f"x={p.position.x:.3f} y={p.position.y:+.3f} z={p.position.z:.3f} yaw={p.yaw:+.2f} "
            f"q={p.q_value:.3f}  -> {outcome:<13s} {left}".rstrip())


def kind_label(kind: int) -> str:
    try:
        return PrimitiveKind(kind).label
    except ValueError:
        return "?"


def format_result(result) -> str:
    """The episode's end and metrics, one per line; an episode that failed before its first action (a
    request the cell refused, e.g. an unknown palette, a lost node) or that ended before its scene was ready
    (counted nothing, e.g. canceled during the reset) prints its reason alone: no metrics."""
    counted_nothing = result.counted_by == COUNTED_BY_NOTHING
    if result.actions == 0 and (is_failure(result.termination_reason) or counted_nothing):
        return (f"episode {result.episode_id or '(none)'}: {result.termination_reason}\n"
                "  no action was taken")
    perception = result.counted_by == "perception"
    lines = [
        f"episode {result.episode_id}: {result.termination_reason}",
        (f"  targets picked   {result.targets_picked} (judged by perception)" if perception else
         f"  targets picked   {result.targets_picked}/{result.targets_total}")
        + (f" ({result.targets_outside} outside the workspace: cannot be picked)" if result.targets_outside
           else ""),
        f"  actions          {result.actions} ({result.pushes} pushes, {result.grasp_attempts} grasps, "
        f"{result.grasp_successes} lifted something, {result.false_rejects} false rejects)",
        f"  grasp success    {100 * result.grasp_success:.1f} %",
        f"  action efficiency {100 * result.action_efficiency:.1f} %",
        f"  record           {result.record_path}",
    ]
    if perception and result.truth_targets_picked >= 0:  # a simulated cell as the hardware
        lines.insert(2, f"  simulator truth  {result.truth_targets_picked}/{result.truth_targets_total} "
                        f"picked; verdicts agree on {result.verdicts_agreeing}/{result.verdicts_checked} "
                        "grasps")
    return "\n".join(lines)


class CtrlC:
    """Ctrl-C (SIGINT) counted by a handler that only adds one, read by the client's waiting loops. A
    KeyboardInterrupt raised wherever the signal lands can surface inside rclpy's C++ calls as another
    error (seen: a TypeError out of the action client's take_feedback), and the goal would be left
    running; the loops read the count between spins instead."""

    def __init__(self):
        self.count = 0

    def __call__(self, signum, frame) -> None:
        self.count += 1


def _spin_until(node, done, seconds: float, ctrl_c: CtrlC | None, presses: int = 1) -> bool:
    """Spin until done() (True: a future's done, a server's ready), or `seconds` passed or Ctrl-C was
    pressed `presses` times (False). Without ctrl_c a KeyboardInterrupt from Python's own handler
    propagates."""
    deadline = time.monotonic() + seconds
    while not done():
        if time.monotonic() > deadline or (ctrl_c is not None and ctrl_c.count >= presses):
            return False
        rclpy.spin_once(node, timeout_sec=0.1)
    return True


def run_episode(node, goal: RunEpisode.Goal, timeout: float, printer=print, ctrl_c: CtrlC | None = None):
    """Send the goal, print feedback as it comes; returns the result (None if rejected). Ctrl-C while the
    episode runs cancels the goal and waits up to CANCEL_TIMEOUT s for the episode's result ("canceled":
    no new motion, the one in progress stopped); a second Ctrl-C leaves at once (KeyboardInterrupt). With
    ctrl_c (a CtrlC installed as the SIGINT handler) the presses are read from it, else Python's
    KeyboardInterrupt is caught. A Ctrl-C while the goal is being sent waits for its answer and cancels
    an accepted goal at once. The action client lives for this episode only (clients left behind pile up
    in the node)."""
    client = RaceFreeActionClient(node, RunEpisode, RUN_EPISODE_ACTION)
    interrupted = False

    def pressed(times: int = 1) -> bool:
        return (ctrl_c is not None and ctrl_c.count >= times) or (interrupted and times == 1)

    try:
        if not _spin_until(node, client.server_is_ready, min(timeout, 60.0), ctrl_c):
            if pressed():
                raise KeyboardInterrupt
            raise TimeoutError(f"action server {RUN_EPISODE_ACTION} not available (is the cell running?)")

        def wait(predicate, seconds: float) -> bool:  # a first Ctrl-C waits on for the server's answer
            nonlocal interrupted
            if pressed(2):
                return False
            try:
                return _spin_until(node, predicate, seconds, ctrl_c, presses=2)
            except KeyboardInterrupt:
                if interrupted:
                    raise
                interrupted = True  # an accepted goal is canceled below
                return _spin_until(node, predicate, seconds, None)

        def adopted() -> None:
            if not pressed(2):
                printer(f"episode_client: the goal's acceptance was lost on the way (rmw: 'failed to send "
                        f"response'), but {RUN_EPISODE_ACTION} reports on the goal: following it")

        handle = client.send_goal_following(
            goal, wait, feedback_callback=lambda fb: printer(format_step(fb.feedback.step)), on_adopt=adopted)
        if pressed(2):
            raise KeyboardInterrupt
        if handle is None:
            if pressed():
                raise KeyboardInterrupt
            raise TimeoutError(f"{RUN_EPISODE_ACTION} did not answer the goal within 30 s")
        if not handle.accepted:
            return None
        result_future = handle.get_result_async()
        try:
            done = not pressed() and _spin_until(node, result_future.done, timeout, ctrl_c)
        except KeyboardInterrupt:
            interrupted, done = True, False
        if not done and not pressed():
            handle.cancel_goal_async()
            raise TimeoutError(f"episode did not finish within {timeout:.0f} s")
        if not done:
            printer("episode_client: Ctrl-C: canceling the episode (Ctrl-C again to leave at once)")
            handle.cancel_goal_async()
            if not _spin_until(node, result_future.done, CANCEL_TIMEOUT, ctrl_c, presses=2):
                if pressed(2):
                    raise KeyboardInterrupt
                raise TimeoutError(f"the episode did not confirm the cancel within {CANCEL_TIMEOUT:.0f} "
                                   "s: stop the cell (Ctrl-C on launch_cell) or the arm (pendant)")
        return result_future.result().result
    finally:
        client.destroy()


def field_int(field: str):
    """An argparse type for the integer option feeding the request's `field`: refused (with the option's
    name, by argparse) outside core.episode.FIELD_RANGES, the messages' own range narrowed to a usable one."""
    low, high = FIELD_RANGES[field]

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: '{text}'") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be an integer from {low} to {high} (got {value})")
        return value

    parse.__name__ = f"{field} value"
    return parse


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: '{text}'") from None
    if not value > 0:  # also NaN
        raise argparse.ArgumentTypeError(f"must be > 0 (got {text})")
    return value


def parse_args(argv=None) -> argparse.Namespace:
    """The options; exits 2 with argparse's usage message on a bad value or a request that
    validate_request refuses (naming the option, or the request field and its reason)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=Scenario.RANDOM.value,
                        choices=[scenario.value for scenario in EPISODE_SCENARIOS])
    parser.add_argument("--seed", type=field_int("seed"), default=0)
    parser.add_argument("--targets", type=field_int("num_targets"), default=2, help="impurities (>= 1)")
    parser.add_argument("--objects", type=field_int("num_objects"), default=20,
                        help="product blocks (>= the targets)")
    parser.add_argument("--max-actions", type=field_int("max_actions"), default=0, help="0: 15 per target")
    parser.add_argument("--scene-file", default="")
    parser.add_argument("--palette", default="", help="simulated cell: a named palette or random-<seed> "
                        "(see README, 'Appearance'); empty: the default blue/red palette")
    parser.add_argument("--timeout", type=positive_float, default=900.0, help="s for the whole episode")
    parser.add_argument("--namespace", default="", help="the cell's ROS namespace (launch_cell --namespace), "
                        "e.g. /cell_a; default: the root")
    route = parser.add_mutually_exclusive_group()
    route.add_argument("--start-only", action="store_true",
                       help=f"use the {START_EPISODE_SERVICE} service and return once it answers (after "
                            "the scene reset, or the episode node's start_wait)")
    route.add_argument("--stop", action="store_true",
                       help=f"stop the running episode ({STOP_EPISODE_SERVICE}): it ends canceled, a motion "
                            "under way is stopped; the other options are ignored")
    args = parser.parse_args(argv)
    try:
        args.namespace = namespace_of(args.namespace)
    except ValueError as error:
        parser.error(f"--{error}")
    args.request = EpisodeRequest(scenario=args.scenario, seed=args.seed, num_targets=args.targets,
                                  num_objects=args.objects, max_actions=args.max_actions,
                                  scene_file=args.scene_file, palette=args.palette)
    reason = None if args.stop else validate_request(args.request)
    if reason is not None:
        for field, option in OPTION_OF_FIELD.items():  # the reason in this command line's words
            reason = reason.replace(field, option)
        parser.error(f"request refused: {reason}")
    return args


def call(node, srv_type, name: str, request, ctrl_c: CtrlC, timeout: float = 30.0, resend: bool = False):
    """One call of service `name`: its response, or TimeoutError (not available / no answer within
    `timeout` s), KeyboardInterrupt (Ctrl-C; twice once the request is out). resend: an idempotent query
    is sent again every 5 s while unanswered (a response can be lost while the client's reader is not
    matched yet)."""
    client = node.create_client(srv_type, name)
    name = absolute(name, node.get_namespace())
    try:
        if not _spin_until(node, client.service_is_ready, 60.0, ctrl_c):
            if ctrl_c.count:
                raise KeyboardInterrupt
            raise TimeoutError(f"service {name} not available (is the cell running?)")
        deadline = time.monotonic() + timeout
        while True:
            future = client.call_async(request)
            wait = min(5.0, deadline - time.monotonic()) if resend else timeout
            if _spin_until(node, future.done, max(wait, 0.1), ctrl_c, presses=2):
                return future.result()
            client.remove_pending_request(future)
            if ctrl_c.count >= 2:
                raise KeyboardInterrupt
            if not resend or time.monotonic() >= deadline:
                raise TimeoutError(f"{name} did not answer within {timeout:.0f} s")
    finally:
        node.destroy_client(client)


def rejection_reason(node, ctrl_c: CtrlC) -> str:
    """Why /episode/run rejected a goal that passed validate_request here: the cell's state, as the
    episode node's /episode/status tells it now (busy, two drivers)."""
    try:
        status = call(node, Trigger, EPISODE_STATUS_SERVICE, Trigger.Request(), ctrl_c, timeout=15.0,
                      resend=True)
    except TimeoutError as error:
        return f"see the episode node's log for the reason ({error})"
    if not status.success:
        return status.message
    return (f"the episode node reports no reason now ({status.message}): its state changed since; "
            "try again, or see its log")


def main(argv=None) -> int:
    args = parse_args(argv)
    request = args.request
    fields = dataclasses.asdict(request)  # the messages' fields, by the same names
    # Our own SIGINT handler (CtrlC: counted, read between spins), not rclpy's, which would shut the
    # context down before the cancel could be sent
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    ctrl_c = CtrlC()
    signal.signal(signal.SIGINT, ctrl_c)
    node = rclpy.create_node("episode_client", namespace=args.namespace or None)
    try:
        if args.stop:
            response = call(node, Trigger, STOP_EPISODE_SERVICE, Trigger.Request(), ctrl_c, STOP_TIMEOUT)
            print(f"episode_client: {response.message}")
            return 0 if response.success else 1
        route = START_EPISODE_SERVICE if args.start_only else RUN_EPISODE_ACTION
        print(f"episode_client: {describe_request(request)} ({absolute(route, node.get_namespace())})",
              flush=True)
        if args.start_only:
            response = call(node, StartEpisode, START_EPISODE_SERVICE, StartEpisode.Request(**fields), ctrl_c)
            print(f"accepted={response.accepted} episode_id={response.episode_id} {response.reason}")
            return 0 if response.accepted else 1
        result = run_episode(node, RunEpisode.Goal(**fields), args.timeout, ctrl_c=ctrl_c)
        if result is None:
            print(f"goal rejected: {rejection_reason(node, ctrl_c)}", file=sys.stderr)
            return 1
        print(format_result(result))
        if result.termination_reason == TERMINATION_CANCELED:
            return 130  # as a shell reports Ctrl-C
        return 1 if is_failure(result.termination_reason) else 0  # node_lost, stale_input, error
    except TimeoutError as error:
        print(f"episode_client: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # before the goal was accepted, or a second Ctrl-C while canceling
        print("episode_client: interrupted", file=sys.stderr)
        return 130
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
