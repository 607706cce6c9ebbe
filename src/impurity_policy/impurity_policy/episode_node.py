"""Episode node: runs the picking loop (core/picking.py, paper section 4) over the node graph.

It serves /episode/start and /episode/run, and runs each episode with the one picking loop against a
RosCell (ros_cell.py): attention -> policy decision -> driver motion -> targets left, until every target
is picked, the action limit, repeated failure, a cancel, or a node of the graph stops answering (or its
inputs are stamped on another clock). Every decision it executes comes from a camera frame stamped after
the previous motion finished. A cancel of /episode/run is honoured in every wait (within
ros_cell.CANCEL_POLL s; a motion under way is stopped by the driver) and the goal ends CANCELED with its
records closed.

It also serves /episode/stop (std_srvs/Trigger): the running episode, however it was started, ends
"canceled" as a cancel would end it; and /episode/status (Trigger): whether an episode could start now
(success false: the reason, e.g. "busy: ..."). Requests are refused, with one reason, when
core.episode.validate_request refuses them, while an episode runs, and while more than one action server
serves the driver's action (every primitive would run on each). A node stopped mid-episode (SIGINT) ends
the episode "canceled" and closes its records before it goes.
"""

import os
import pathlib
import threading
import time
import uuid
from dataclasses import dataclass, field

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from std_srvs.srv import Trigger

from impurity_common import names
from impurity_common.conversions import ns_to_time
from impurity_common.diagnostics import OK, WARN, Diagnostics, Status
from impurity_common.node_main import spin_node
from impurity_common.parameters import declare_parameters, param
from impurity_interfaces.action import RunEpisode
from impurity_interfaces.msg import EpisodeStep
from impurity_interfaces.srv import StartEpisode
from impurity_policy.core.episode import (
    TERMINATION_CANCELED,
    EpisodeRecorder,
    EpisodeRequest,
    StepRecord,
    describe_request,
    is_failure,
    validate_request,
)
from impurity_policy.core.picking import EpisodeCanceled, EpisodeLimits, run_episode
from impurity_policy.ros_cell import RosCell, RosCellTimeouts

STOP_WAIT = 30.0  # s /episode/stop waits for the episode's end (a motion under way stops, the arm parks)
NODE_STOP_WAIT = 10.0  # s a node being stopped waits for the running episode to close its records
DRIVER_STATUS_TOPIC = names.EXECUTE_PRIMITIVE_ACTION + "/_action/status"  # one publisher per action server


def default_record_dir() -> str:
    root = os.environ.get("IMPURITY_CELL_ROOT")
    return str(pathlib.Path(root) / "runs" / "episodes") if root else str(
        pathlib.Path.home() / ".ros" / "impurity_episodes")


@dataclass(frozen=True)
class EpisodeParameters(EpisodeLimits, RosCellTimeouts):
    """Everything bringup/config/cell.yaml may set for the episode node: the episode's limits and verdict
    (picking.EpisodeLimits, verdict.VerdictParams as verdict.<name>), the cell's waits
    (ros_cell.RosCellTimeouts; an instance serves as either) and the node's own settings below."""

    record_dir: str = param("", "Directory of episode records (JSON lines); empty: runs/episodes in the "
                                "checkout, else ~/.ros/impurity_episodes")
    start_wait: float = param(10.0, "/episode/start: s to wait for the episode's scene reset before "
                              "answering; a reset that fails within it (e.g. an unknown palette) refuses the "
                              "start with its reason; one still under way is answered accepted, and should "
                              "it fail later the log and the record say why (a missing cell takes "
                              "service_timeout to fail); 0: answer at once", low=0.0)
    use_ground_truth: bool = param(True, "Sim: reset scenes and count targets from ground truth; false "
                                   "(a real cell): no target count, the episode ends by perception and each "
                                   "grasp is judged by perception")


@dataclass
class RunningEpisode:
    """The episode under way: its id, who started it (the service or the action), the stop request
    (/episode/stop, or the node stopping) and, once it ended, its termination reason and record."""

    episode_id: str
    route: str
    stop: threading.Event = field(default_factory=threading.Event)
    ended: threading.Event = field(default_factory=threading.Event)
    termination_reason: str = ""
    recorder: EpisodeRecorder | None = None


class EpisodeNode(Node):
    def __init__(self):
        super().__init__("episode")
        self.params = declare_parameters(self, EpisodeParameters)
        self.record_dir = self.params.record_dir or default_record_dir()
        group = ReentrantCallbackGroup()
        self._lock = threading.Lock()  # guards self._running: claimed and released as one step
        self._running: RunningEpisode | None = None
        self._driver_status_topic = self.resolve_topic_name(DRIVER_STATUS_TOPIC)
        self._cell = RosCell(self, group, self.params, self.params.use_ground_truth)
        self._steps_pub = self.create_publisher(EpisodeStep, names.EPISODE_STEPS_TOPIC, 10)
        self.create_service(StartEpisode, names.START_EPISODE_SERVICE, self._on_start, callback_group=group)
        self.create_service(Trigger, names.STOP_EPISODE_SERVICE, self._on_stop, callback_group=group)
        self.create_service(Trigger, names.EPISODE_STATUS_SERVICE, self._on_status, callback_group=group)
        self._action_server = ActionServer(
            self, RunEpisode, names.RUN_EPISODE_ACTION, execute_callback=self._execute_goal,
            goal_callback=self._on_goal, cancel_callback=lambda _: CancelResponse.ACCEPT,
            callback_group=group)
        self.diagnostics = Diagnostics(self, self._status)
        self.get_logger().info(f"ready; records go to {self.record_dir}")

    def _status(self) -> Status:
        """The running episode, or idle; WARN when no episode could start (/episode/status's reason)."""
        running = self._running
        values = {"episode": running.episode_id if running is not None else "none",
                  "use ground truth": self.params.use_ground_truth, "record dir": str(self.record_dir)}
        if running is not None:
            return Status(OK, f"running episode {running.episode_id} (started by {running.route})", values)
        reason = self._state_refusal()
        if reason is not None:
            return Status(WARN, reason, values)
        return Status(OK, "idle: ready for an episode", values)

    # ---- requests -----------------------------------------------------------------------------
    @staticmethod
    def _request_from(fields) -> EpisodeRequest:
        return EpisodeRequest(scenario=fields.scenario, seed=int(fields.seed),
                              num_targets=int(fields.num_targets), num_objects=int(fields.num_objects),
                              max_actions=int(fields.max_actions), scene_file=fields.scene_file,
                              palette=fields.palette)

    def _state_refusal(self) -> str | None:
        """Why no episode can start now, whatever it asks (None: one can): an episode is running, or more
        than one action server serves the driver's action (counted as publishers of its status topic)."""
        running = self._running
        if running is not None:
            return f"busy: an episode is already running ({running.episode_id}, started by {running.route})"
        drivers = self.count_publishers(self._driver_status_topic)
        if drivers > 1:
            return (f"{drivers} action servers serve {self._name(names.EXECUTE_PRIMITIVE_ACTION)} ({drivers} "
                    f"publishers of {self._driver_status_topic}): every primitive would run on each of them; "
                    "stop all drivers but one (an action is renamed by remapping its internal topics and "
                    "services, not its name: README, 'Running on a real cell')")
        return None

    def _refusal(self, request: EpisodeRequest) -> str | None:
        return validate_request(request) or self._state_refusal()

    def _name(self, name: str) -> str:
        """A name of impurity_common.names as it resolves in this node's namespace (for messages)."""
        return names.absolute(name, self.get_namespace())

    def _claim(self, request: EpisodeRequest, route: str) -> tuple[RunningEpisode | None, str | None]:
        """(the new running episode, None), or (None, why it is refused): checked and claimed at once."""
        with self._lock:
            reason = self._refusal(request)
            if reason is not None:
                return None, reason
            self._running = RunningEpisode(_new_episode_id(), route)
            return self._running, None

    def _on_start(self, request, response):
        episode_request = self._request_from(request)
        running, reason = self._claim(episode_request, self._name(names.START_EPISODE_SERVICE))
        if reason is not None:
            self.get_logger().warning(f"start refused: {reason}")
            response.accepted, response.reason = False, reason
            return response
        started, answered = threading.Event(), threading.Event()

        def run():
            try:
                self._run_and_release(running, episode_request, None,
                                      on_started=lambda: (started.set(), answered.set()))
            except Exception as error:  # noqa: BLE001 - before the loop (e.g. its record could not be opened)
                running.termination_reason = f"error: {error!r}"
                self.get_logger().error(f"episode {running.episode_id} failed before it started: {error!r}")
            finally:
                answered.set()

        threading.Thread(target=run, daemon=True).start()
        # `started` is set before `answered`: an answer without it is an episode that ended before its reset
        # was done; no answer within start_wait is a reset still under way (accepted)
        done = answered.wait(self.params.start_wait)
        response.episode_id = running.episode_id
        if not done or started.is_set():
            response.accepted = True
        else:  # refused: the episode never ran, its folder goes (episodes.jsonl keeps its line); one
            # stopped by /episode/stop keeps it: the stop's answer names it
            reason = running.termination_reason or "error: the episode ended before its scene reset"
            if running.recorder is not None and not running.stop.is_set():
                running.recorder.discard()
            self.get_logger().warning(
                f"start refused: episode {running.episode_id} could not start: {reason}")
            response.accepted, response.reason = False, reason
        return response

    def _on_stop(self, _request, response):
        """/episode/stop: the running episode ends "canceled" (no new motion; one under way is stopped by
        the driver); answered once it ended (or after STOP_WAIT s, still stopping)."""
        running = self._running
        if running is None:
            response.success, response.message = False, "no episode is running"
            return response
        self.get_logger().info(f"stop requested: episode {running.episode_id} ends canceled")
        running.stop.set()
        response.success = True
        if running.ended.wait(STOP_WAIT):
            record = running.recorder.directory if running.recorder is not None else "(none)"
            response.message = (f"episode {running.episode_id} ended: {running.termination_reason}; "
                                f"record {record}")
        else:
            response.message = (f"episode {running.episode_id} is stopping (not ended within {STOP_WAIT:.0f} "
                                "s: a motion is being stopped); its record will say how it ended")
        return response

    def _on_status(self, _request, response):
        """/episode/status: success true when an episode could start now; else the reason (busy, ...)."""
        reason = self._state_refusal()
        response.success = reason is None
        response.message = reason or "ready: no episode is running"
        return response

    def _on_goal(self, goal) -> GoalResponse:
        reason = self._refusal(self._request_from(goal))
        if reason is not None:
            self.get_logger().warning(f"goal rejected: {reason}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _execute_goal(self, goal_handle):
        result = RunEpisode.Result()
        request = self._request_from(goal_handle.request)
        running, reason = self._claim(request, self._name(names.RUN_EPISODE_ACTION))
        if reason is not None:  # claimed by another request since the goal was accepted
            self.get_logger().warning(f"goal aborted: {reason}")
            goal_handle.abort()
            result.termination_reason = reason
            return result
        summary = self._run_and_release(running, request, goal_handle)
        for key, value in summary.items():
            if hasattr(result, key) and key != "record_path" and value is not None:
                setattr(result, key, type(getattr(result, key))(value))
        result.record_path = summary.get("record_path", "")
        if not self.context.ok():  # the node is being stopped: the goal's end cannot be sent
            return result
        reason = summary["termination_reason"]
        if reason == TERMINATION_CANCELED and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        elif is_failure(reason) or reason == TERMINATION_CANCELED:
            goal_handle.abort()  # also a stop by /episode/stop: no cancel of the goal was asked
        else:
            goal_handle.succeed()
        return result

    def _run_and_release(self, running: RunningEpisode, request, goal_handle, on_started=None) -> dict:
        try:
            summary = self._run_episode(running, request, goal_handle, on_started)
            running.termination_reason = summary["termination_reason"]
            return summary
        finally:
            with self._lock:
                self._running = None
            running.ended.set()

    def destroy_node(self) -> None:
        """A running episode is stopped first (it ends "canceled", its records closed), waited for up to
        NODE_STOP_WAIT s. After SIGINT the context is already shut down: a motion under way can no longer be
        canceled from here, and the driver finishes it."""
        running = self._running
        if running is not None:
            self.get_logger().warning(f"node stopping: episode {running.episode_id} ends canceled")
            running.stop.set()
            if not running.ended.wait(NODE_STOP_WAIT):
                self.get_logger().error(f"episode {running.episode_id} did not close its records within "
                                        f"{NODE_STOP_WAIT:.0f} s")
        super().destroy_node()

    # ---- the loop -----------------------------------------------------------------------------
    def _run_episode(self, running: RunningEpisode, request: EpisodeRequest, goal_handle,
                     on_started=None) -> dict:
        """One episode through the picking loop; the summary it recorded. It stops on a cancel of its
        goal, /episode/stop or the node stopping (running.stop). on_started: see picking.run_episode."""
        log = self.get_logger()
        episode_id = running.episode_id
        recorder = running.recorder = EpisodeRecorder(self.record_dir, episode_id, request)
        log.info(f"episode {episode_id}: {describe_request(request)}")
        summary = run_episode(
            StoppingCell(self._cell, self.context), request, episode_id, self.params, recorder=recorder,
            on_step=lambda step: self._publish_step(episode_id, step, goal_handle),
            should_stop=lambda: running.stop.is_set() or not self.context.ok() or (
                goal_handle is not None and goal_handle.is_cancel_requested),
            clock_ns=lambda: self.get_clock().now().nanoseconds,
            on_error=lambda error: log.error(f"episode {episode_id} failed: {error!r}"),
            on_started=on_started)
        outside = summary.get("targets_outside", 0)
        outside_note = f" ({outside} outside the workspace)" if outside else ""
        total = summary["targets_total"] if summary["targets_total"] >= 0 else "?"
        audit = ""
        if summary.get("truth_targets_picked", -1) >= 0:
            audit = (f"; truth: {summary['truth_targets_picked']} picked, verdicts agree on "
                     f"{summary['verdicts_agreeing']}/{summary['verdicts_checked']} grasp(s)")
        log.info(f"episode {episode_id} ended ({summary['termination_reason']}): picked "
                 f"{summary['targets_picked']}/{total}{outside_note} in {summary['actions']} actions "
                 f"(counted by {summary['counted_by']}){audit}; record {recorder.directory}")
        return summary

    # ---- outputs ------------------------------------------------------------------------------
    def _publish_step(self, episode_id: str, step: StepRecord, goal_handle) -> None:
        """The step on /episode/steps (the policy node remembers tried actions from it) and as feedback;
        only logged once the node is stopping (its context shut down: nothing can be sent)."""
        if not self.context.ok():
            self.get_logger().info(f"step {step.step} recorded; not published: the node is stopping")
            return
        msg = EpisodeStep(episode_id=episode_id, step=step.step, attention_mode=step.attention_mode,
                          primitive=self._cell.last_primitive, success=step.success,
                          target_grasped=step.target_grasped, targets_remaining=step.targets_remaining,
                          motion_finished=ns_to_time(step.motion_finished_ns),
                          motion_completed=step.motion_completed, gripper_opening=step.gripper_opening,
                          holding=step.holding, target_gone_fraction=step.gone_fraction,
                          verdict=step.verdict)
        self._steps_pub.publish(msg)
        if goal_handle is not None:
            goal_handle.publish_feedback(RunEpisode.Feedback(step=msg))
        self.get_logger().info(
            f"step {step.step}: {step.kind} at ({step.position[0]:.3f}, {step.position[1]:.3f}) yaw "
            f"{step.yaw:.2f} q {step.q_value:.3f} -> {'ok' if step.success else 'failed'}; "
            + (f"{step.targets_remaining} target(s) left" if step.targets_remaining >= 0 else
               (step.verdict or "not judged")))


class StoppingCell:
    """The RosCell as the picking loop sees it, where an error raised once the node's context is shut down
    (SIGINT: rclpy shuts it down before the node can stop its episode; a graph query then fails with
    "context is invalid") is the episode's stop, EpisodeCanceled, not an error of the cell."""

    def __init__(self, cell: RosCell, context):
        self._cell, self._context = cell, context

    def __getattr__(self, name):
        verb = getattr(self._cell, name)
        if not callable(verb):
            return verb

        def call(*args, **kwargs):
            try:
                return verb(*args, **kwargs)
            except Exception as error:
                if self._context.ok() or isinstance(error, EpisodeCanceled):
                    raise
                raise EpisodeCanceled(f"the episode node stopped ({error!r})") from error

        return call


def _new_episode_id() -> str:
    return time.strftime("%Y%m%d-%H%M%S-") + uuid.uuid4().hex[:6]


def main(args=None):
    spin_node(EpisodeNode, args=args, executor_factory=lambda: MultiThreadedExecutor(num_threads=4))


if __name__ == "__main__":
    main()
