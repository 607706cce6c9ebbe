"""Episode node: runs the picking loop (core/picking.py, paper section 4) over the node graph.

It serves /episode/start and /episode/run, and runs each episode with the one picking loop against a
RosCell (ros_cell.py): attention -> policy decision -> driver motion -> targets left, until every target
is picked, the action limit, repeated failure, a cancel, or a node of the graph stops answering (or its
inputs are stamped on another clock). Every decision it executes comes from a camera frame stamped after
the previous motion finished. A cancel of /episode/run is honoured in every wait (within
ros_cell.CANCEL_POLL s; a motion under way is stopped by the driver) and the goal ends CANCELED with its
records closed.
"""

import os
import pathlib
import threading
import time
import uuid
from dataclasses import dataclass

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node

from impurity_common import names
from impurity_common.conversions import ns_to_time
from impurity_common.node_main import spin_node
from impurity_common.parameters import declare_parameters, param
from impurity_interfaces.action import RunEpisode
from impurity_interfaces.msg import EpisodeStep
from impurity_interfaces.srv import StartEpisode
from impurity_policy.core.episode import (
    DEFAULT_ACTIONS_PER_TARGET,
    DEFAULT_MAX_ACTIONS_UNCOUNTED,
    DEFAULT_MAX_CONSECUTIVE_FAILURES,
    DEFAULT_NONE_FRAMES_TO_FINISH,
    TERMINATION_CANCELED,
    EpisodeRecorder,
    EpisodeRequest,
    StepRecord,
    is_failure,
    validate_request,
)
from impurity_policy.core.picking import EpisodeLimits, run_episode
from impurity_policy.core.verdict import VerdictParams
from impurity_policy.ros_cell import RosCell, RosCellTimeouts

VERDICT = VerdictParams()


def default_record_dir() -> str:
    root = os.environ.get("IMPURITY_CELL_ROOT")
    return str(pathlib.Path(root) / "runs" / "episodes") if root else str(
        pathlib.Path.home() / ".ros" / "impurity_episodes")


@dataclass(frozen=True)
class EpisodeParameters:
    """Everything bringup/config/cell.yaml may set for the episode node."""

    record_dir: str = param("", "Directory of episode records (JSON lines); empty: runs/episodes in the "
                                "checkout, else ~/.ros/impurity_episodes")
    actions_per_target: int = param(DEFAULT_ACTIONS_PER_TARGET, "Action limit per target in the workspace "
                                    "when a request gives max_actions 0", low=1, high=1000)
    max_consecutive_failures: int = param(DEFAULT_MAX_CONSECUTIVE_FAILURES,
                                          "Failed grasps (nothing lifted) or pushes whose motion failed, "
                                          "in a row, that end the episode; a motion the driver refuses "
                                          "ends it at once", low=1, high=1000)
    decision_timeout: float = param(30.0, "s to wait for a fresh decision before giving up (node_lost, or "
                                    "stale_input when the attention results are stamped on another clock)",
                                    low=0.1)
    motion_timeout: float = param(120.0, "s to wait for the driver to finish a motion", low=0.1)
    service_timeout: float = param(30.0, "s to wait for a service (reset, ground truth)", low=0.1)
    start_wait: float = param(10.0, "/episode/start: s to wait for the episode's scene reset before "
                              "answering; a reset that fails within it (e.g. an unknown palette) refuses the "
                              "start with its reason; one still under way is answered accepted, and should "
                              "it fail later the log and the record say why (a missing cell takes "
                              "service_timeout to fail); 0: answer at once", low=0.0)
    use_ground_truth: bool = param(True, "Sim: reset scenes and count targets from ground truth; false "
                                   "(a real cell): no target count, the episode ends by perception and each "
                                   "grasp is judged by perception")
    none_frames_to_finish: int = param(DEFAULT_NONE_FRAMES_TO_FINISH, "Without ground truth: consecutive "
                                       "fresh frames on which attention answers NONE that end the episode",
                                       low=1, high=100)
    max_actions_uncounted: int = param(DEFAULT_MAX_ACTIONS_UNCOUNTED, "Without ground truth: action limit "
                                       "when a request gives max_actions 0", low=1, high=10000)
    scene_service_timeout: float = param(3.0, "Without ground truth: s to wait for a simulated cell's "
                                         "reset and ground-truth services (a real cell has none; 0: never "
                                         "ask)", low=0.0)
    verdict_min_height_drop: float = param(VERDICT.min_height_drop, "Grasp verdict: m a target cell's "
                                           "height must fall to count as changed", low=0.001)
    verdict_min_color_change: float = param(VERDICT.min_color_change, "Grasp verdict: RGB distance "
                                            "(0-255) that counts a target cell as changed", low=1.0)
    verdict_min_gone_fraction: float = param(VERDICT.min_gone_fraction, "Grasp verdict: share of the "
                                             "attended target's cells that must have changed", low=0.01,
                                             high=1.0)
    verdict_closed_opening: float = param(VERDICT.closed_opening, "Grasp verdict: m between the fingers at "
                                          "or below which the gripper holds nothing (when the driver does "
                                          "not report holding)", low=0.0)
    verdict_min_target_score: float = param(VERDICT.min_target_score, "Grasp verdict: saliency contrast "
                                            "(attention score) a lifted TARGET needs to count as an "
                                            "impurity (products taken for targets score lower)", low=0.0)
    verdict_min_color_contrast: float = param(VERDICT.min_color_contrast, "Grasp verdict: colour distance "
                                              "a lifted TARGET must keep from the other objects' median "
                                              "colour, in units of their colour spread, to count as an "
                                              "impurity; 0: no colour test", low=0.0)


class EpisodeNode(Node):
    def __init__(self):
        super().__init__("episode")
        self.params = declare_parameters(self, EpisodeParameters)
        self.record_dir = self.params.record_dir or default_record_dir()
        group = ReentrantCallbackGroup()
        self._busy = threading.Lock()
        self._cell = RosCell(self, group, RosCellTimeouts(self.params.decision_timeout,
                                                          self.params.motion_timeout,
                                                          self.params.service_timeout,
                                                          self.params.scene_service_timeout),
                             self.params.use_ground_truth)
        self._limits = EpisodeLimits(
            self.params.actions_per_target, self.params.max_consecutive_failures,
            self.params.none_frames_to_finish, self.params.max_actions_uncounted,
            VerdictParams(self.params.verdict_min_height_drop, self.params.verdict_min_color_change,
                          self.params.verdict_min_gone_fraction, self.params.verdict_closed_opening,
                          self.params.verdict_min_target_score, self.params.verdict_min_color_contrast))
        self._steps_pub = self.create_publisher(EpisodeStep, names.EPISODE_STEPS_TOPIC, 10)
        self.create_service(StartEpisode, names.START_EPISODE_SERVICE, self._on_start, callback_group=group)
        self._action_server = ActionServer(
            self, RunEpisode, names.RUN_EPISODE_ACTION, execute_callback=self._execute_goal,
            goal_callback=self._on_goal, cancel_callback=lambda _: CancelResponse.ACCEPT,
            callback_group=group)
        self.get_logger().info(f"ready; records go to {self.record_dir}")

    # ---- requests -----------------------------------------------------------------------------
    @staticmethod
    def _request_from(fields) -> EpisodeRequest:
        return EpisodeRequest(scenario=fields.scenario, seed=int(fields.seed),
                              num_targets=int(fields.num_targets), num_objects=int(fields.num_objects),
                              max_actions=int(fields.max_actions), scene_file=fields.scene_file,
                              palette=fields.palette)

    def _refusal(self, request: EpisodeRequest) -> str | None:
        reason = validate_request(request)
        if reason is None and self._busy.locked():
            reason = "busy: an episode is already running"
        return reason

    def _on_start(self, request, response):
        episode_request = self._request_from(request)
        reason = self._refusal(episode_request)
        if reason is None and not self._busy.acquire(blocking=False):
            reason = "busy: an episode is already running"
        if reason is not None:
            self.get_logger().warning(f"start refused: {reason}")
            response.accepted, response.reason = False, reason
            return response
        episode_id = _new_episode_id()
        started, answered, ended = threading.Event(), threading.Event(), {}

        def run():
            try:
                summary = self._run_and_release(episode_id, episode_request, None,
                                                on_started=lambda: (started.set(), answered.set()))
                ended["reason"] = summary["termination_reason"]
            except Exception as error:  # noqa: BLE001 - before the loop (e.g. its record could not be opened)
                ended["reason"] = f"error: {error!r}"
                self.get_logger().error(f"episode {episode_id} failed before it started: {error!r}")
            finally:
                answered.set()

        threading.Thread(target=run, daemon=True).start()
        # `started` is set before `answered`: an answer without it is an episode that ended before its reset
        # was done; no answer within start_wait is a reset still under way (accepted)
        done = answered.wait(self.params.start_wait)
        response.episode_id = episode_id
        if not done or started.is_set():
            response.accepted = True
        else:
            reason = ended.get("reason", "error: the episode ended before its scene reset")
            self.get_logger().warning(f"start refused: episode {episode_id} could not start: {reason}")
            response.accepted, response.reason = False, reason
        return response

    def _on_goal(self, goal) -> GoalResponse:
        reason = self._refusal(self._request_from(goal))
        if reason is not None:
            self.get_logger().warning(f"goal rejected: {reason}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _execute_goal(self, goal_handle):
        result = RunEpisode.Result()
        if not self._busy.acquire(blocking=False):
            goal_handle.abort()
            result.termination_reason = "busy: an episode is already running"
            return result
        request = self._request_from(goal_handle.request)
        summary = self._run_and_release(_new_episode_id(), request, goal_handle)
        for key, value in summary.items():
            if hasattr(result, key) and key != "record_path" and value is not None:
                setattr(result, key, type(getattr(result, key))(value))
        result.record_path = summary.get("record_path", "")
        if summary["termination_reason"] == TERMINATION_CANCELED:
            goal_handle.canceled()
        elif is_failure(summary["termination_reason"]):
            goal_handle.abort()
        else:
            goal_handle.succeed()
        return result

    def _run_and_release(self, episode_id, request, goal_handle, on_started=None) -> dict:
        try:
            return self._run_episode(episode_id, request, goal_handle, on_started)
        finally:
            self._busy.release()

    # ---- the loop -----------------------------------------------------------------------------
    def _run_episode(self, episode_id: str, request: EpisodeRequest, goal_handle, on_started=None) -> dict:
        """One episode through the picking loop; the summary it recorded. on_started: see
        picking.run_episode."""
        log = self.get_logger()
        recorder = EpisodeRecorder(self.record_dir, episode_id)
        log.info(f"episode {episode_id}: {request.scenario} seed {request.seed}")
        summary = run_episode(
            self._cell, request, episode_id, self._limits, recorder=recorder,
            on_step=lambda step: self._publish_step(episode_id, step, goal_handle),
            should_stop=lambda: goal_handle is not None and goal_handle.is_cancel_requested,
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
        """The step on /episode/steps (the policy node remembers tried actions from it) and as feedback."""
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


def _new_episode_id() -> str:
    return time.strftime("%Y%m%d-%H%M%S-") + uuid.uuid4().hex[:6]


def main(args=None):
    spin_node(EpisodeNode, args=args, executor_factory=lambda: MultiThreadedExecutor(num_threads=4))


if __name__ == "__main__":
    main()
