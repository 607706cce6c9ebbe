"""Episode node: runs the paper's picking loop (section 4) over the node graph.

attention -> policy decision -> driver motion -> ground truth (sim) -> record, until every target is
picked, the action limit, repeated failure, a cancel, or a node of the graph stops answering.
Every decision it executes comes from a camera frame stamped after the previous motion finished.
"""

import collections
import os
import pathlib
import threading
import time
import uuid

import cv2
from rclpy.action import ActionClient, ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from impurity_common.conversions import image_to_numpy, time_to_ns
from impurity_common.node_main import spin_node
from impurity_common.parameters import describe
from impurity_interfaces.action import ExecutePrimitive, RunEpisode
from impurity_interfaces.msg import AttentionResult, EpisodeStep, Primitive
from impurity_interfaces.srv import GetGroundTruth, ResetScene, StartEpisode
from impurity_policy.core.episode import (
    DEFAULT_ACTIONS_PER_TARGET,
    DEFAULT_MAX_CONSECUTIVE_FAILURES,
    TERMINATION_CANCELED,
    TERMINATION_NOTHING_LEFT,
    EpisodeRecorder,
    EpisodeRequest,
    EpisodeTracker,
    StepRecord,
    action_limit,
    draw_episode,
    read_steps,
    validate_request,
)

MODE_NAMES = {AttentionResult.MODE_NONE: "NONE", AttentionResult.MODE_TARGET: "TARGET",
              AttentionResult.MODE_OCCLUDED_REGION: "OCCLUDED_REGION"}


# s without the policy node's publisher, once it had been seen, before an episode gives up on it.
POLICY_GONE_GRACE = 5.0


class EpisodeAborted(Exception):
    """The episode cannot go on; the message is its termination reason."""


def default_record_dir() -> str:
    root = os.environ.get("IMPURITY_CELL_ROOT")
    return str(pathlib.Path(root) / "runs" / "episodes") if root else str(
        pathlib.Path.home() / ".ros" / "impurity_episodes")


class EpisodeNode(Node):
    def __init__(self):
        super().__init__("episode")
        self.declare_parameter("record_dir", default_record_dir(),
                               descriptor=describe("Directory of episode records (JSON lines)"))
        self.declare_parameter("actions_per_target", DEFAULT_ACTIONS_PER_TARGET,
                               descriptor=describe("Action limit per target when a request gives 0"))
        self.declare_parameter("max_consecutive_failures", DEFAULT_MAX_CONSECUTIVE_FAILURES,
                               descriptor=describe("Failed grasps/motions in a row that end the episode"))
        self.declare_parameter("decision_timeout", 30.0,
                               descriptor=describe("s to wait for a fresh decision before giving up"))
        self.declare_parameter("motion_timeout", 120.0,
                               descriptor=describe("s to wait for the driver to finish a motion"))
        self.declare_parameter("service_timeout", 30.0,
                               descriptor=describe("s to wait for a service (reset, ground truth)"))
        self.declare_parameter("use_ground_truth", True,
                               descriptor=describe("Sim: reset scenes and count targets from ground truth"))

        group = ReentrantCallbackGroup()
        self._condition = threading.Condition()
        self._attention_by_stamp: collections.OrderedDict[int, AttentionResult] = collections.OrderedDict()
        self._latest_primitive: Primitive | None = None
        self._policy_seen = False
        self._busy = threading.Lock()

        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        self.create_subscription(AttentionResult, "/attention/result", self._on_attention, reliable,
                                 callback_group=group)
        self.create_subscription(Primitive, "/policy/primitive", self._on_primitive, reliable,
                                 callback_group=group)
        self._steps_pub = self.create_publisher(EpisodeStep, "/episode/steps", 10)
        self._driver = ActionClient(self, ExecutePrimitive, "/ur5/execute_primitive", callback_group=group)
        self._reset = self.create_client(ResetScene, "/cell/reset_scene", callback_group=group)
        self._ground_truth = self.create_client(GetGroundTruth, "/cell/ground_truth", callback_group=group)
        self.create_service(StartEpisode, "/episode/start", self._on_start, callback_group=group)
        self._action_server = ActionServer(
            self, RunEpisode, "/episode/run", execute_callback=self._execute_goal,
            goal_callback=self._on_goal, cancel_callback=lambda _: CancelResponse.ACCEPT,
            callback_group=group)
        self.get_logger().info(f"ready; records go to {self._param('record_dir')}")

    def _param(self, name):
        return self.get_parameter(name).value

    # ---- inputs -------------------------------------------------------------------------------
    def _on_attention(self, msg: AttentionResult) -> None:
        with self._condition:
            self._attention_by_stamp[time_to_ns(msg.header.stamp)] = msg
            while len(self._attention_by_stamp) > 20:
                self._attention_by_stamp.popitem(last=False)
            self._condition.notify_all()

    def _on_primitive(self, msg: Primitive) -> None:
        with self._condition:
            self._latest_primitive = msg
            self._condition.notify_all()

    # ---- requests -----------------------------------------------------------------------------
    @staticmethod
    def _request_from(fields) -> EpisodeRequest:
        return EpisodeRequest(scenario=fields.scenario, seed=int(fields.seed),
                              num_targets=int(fields.num_targets), num_objects=int(fields.num_objects),
                              max_actions=int(fields.max_actions), scene_file=fields.scene_file)

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
        threading.Thread(target=self._run_and_release, args=(episode_id, episode_request, None),
                         daemon=True).start()
        response.accepted, response.episode_id = True, episode_id
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
            if hasattr(result, key) and key != "record_path":
                setattr(result, key, type(getattr(result, key))(value))
        result.record_path = summary.get("record_path", "")
        if summary["termination_reason"] == TERMINATION_CANCELED:
            goal_handle.canceled()
        elif summary["termination_reason"].startswith(("node_lost", "error")):
            goal_handle.abort()
        else:
            goal_handle.succeed()
        return result

    def _run_and_release(self, episode_id, request, goal_handle) -> dict:
        try:
            return self._run_episode(episode_id, request, goal_handle)
        finally:
            self._busy.release()

    # ---- the loop -----------------------------------------------------------------------------
    def _run_episode(self, episode_id: str, request: EpisodeRequest, goal_handle) -> dict:
        log = self.get_logger()
        recorder = EpisodeRecorder(self._param("record_dir"), episode_id)
        tracker = EpisodeTracker(episode_id, request, request.num_targets, 0,
                                 int(self._param("max_consecutive_failures")))
        reason = None
        try:
            targets_total = self._reset_scene(request)
            tracker.targets_total = tracker.targets_remaining = targets_total
            tracker.max_actions = action_limit(request, targets_total, int(self._param("actions_per_target")))
            motion_finished_ns = self.get_clock().now().nanoseconds
            recorder.write_start(request, targets_total, tracker.max_actions, motion_finished_ns)
            log.info(f"episode {episode_id}: {request.scenario} seed {request.seed}, "
                     f"{targets_total} target(s), at most {tracker.max_actions} actions")
            first_view_saved = False
            while reason is None:
                attention, primitive = self._fresh_decision(motion_finished_ns)
                if not first_view_saved:
                    self._save_first_view(recorder.directory, attention)
                    first_view_saved = True
                if attention.mode == AttentionResult.MODE_NONE:
                    reason = TERMINATION_NOTHING_LEFT
                    break
                outcome = self._execute(primitive)
                motion_finished_ns = time_to_ns(outcome.finished)
                remaining = self._targets_remaining(tracker, outcome)
                step = _step_record(tracker.actions + 1, attention, primitive, outcome, remaining)
                tracker.record(step)
                recorder.write_step(step)
                self._publish_step(episode_id, step, primitive, outcome, goal_handle)
                log.info(f"step {step.step}: {step.kind} at ({step.position[0]:.3f}, {step.position[1]:.3f}) "
                         f"yaw {step.yaw:.2f} q {step.q_value:.3f} -> "
                         f"{'ok' if step.success else 'failed'}; {remaining} target(s) left")
                reason = tracker.termination()
                if reason is None and goal_handle is not None and goal_handle.is_cancel_requested:
                    reason = TERMINATION_CANCELED
        except EpisodeAborted as error:
            reason = str(error)
        except Exception as error:  # the record must close whatever went wrong
            log.error(f"episode {episode_id} failed: {error!r}")
            reason = f"error: {error!r}"
        summary = recorder.write_summary(tracker.metrics(), reason)
        self._save_picture(recorder.directory)
        log.info(f"episode {episode_id} ended ({reason}): picked {tracker.targets_picked}/"
                 f"{tracker.targets_total} in {tracker.actions} actions; record {recorder.directory}")
        return summary

    def _reset_scene(self, request: EpisodeRequest) -> int:
        if not self._param("use_ground_truth"):
            return request.num_targets
        response = self._call(self._reset, ResetScene.Request(
            scenario=request.scenario, seed=request.seed, num_targets=request.num_targets,
            num_objects=request.num_objects, scene_file=request.scene_file), "/cell/reset_scene")
        if not response.success:
            raise EpisodeAborted(f"error: scene reset failed: {response.message}")
        return int(response.num_targets)

    def _targets_remaining(self, tracker: EpisodeTracker, outcome) -> int:
        if self._param("use_ground_truth"):
            return int(self._call(self._ground_truth, GetGroundTruth.Request(),
                                  "/cell/ground_truth").targets_remaining)
        return tracker.targets_remaining - (1 if outcome.target_grasped else 0)

    def _call(self, client, request, name: str):
        timeout = float(self._param("service_timeout"))
        if not client.wait_for_service(timeout_sec=timeout):
            raise EpisodeAborted(f"node_lost: service {name} not available within {timeout:.0f} s")
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout):
            raise EpisodeAborted(f"node_lost: no response from {name} within {timeout:.0f} s")
        return future.result()

    def _fresh_decision(self, after_ns: int):
        """The first decision (and its attention result) from a frame stamped after `after_ns`."""
        timeout = float(self._param("decision_timeout"))
        deadline = time.monotonic() + timeout
        gone_since = None
        with self._condition:
            while True:
                primitive = self._latest_primitive
                if primitive is not None and time_to_ns(primitive.header.stamp) > after_ns:
                    attention = self._attention_by_stamp.get(time_to_ns(primitive.header.stamp))
                    if attention is not None:
                        return attention, primitive
                newest = next(reversed(self._attention_by_stamp.values()), None)
                if (newest is not None and time_to_ns(newest.header.stamp) > after_ns
                        and newest.mode == AttentionResult.MODE_NONE):
                    return newest, None
                remaining = deadline - time.monotonic()
                if self.count_publishers("/policy/primitive") > 0:
                    self._policy_seen, gone_since = True, None
                elif self._policy_seen:  # it was there and left; a slow start is decision_timeout's job
                    gone_since = gone_since or time.monotonic()
                    if time.monotonic() - gone_since > POLICY_GONE_GRACE:
                        raise EpisodeAborted("node_lost: the policy node left /policy/primitive")
                if remaining <= 0:
                    raise EpisodeAborted(
                        f"node_lost: no fresh decision on /policy/primitive within {timeout:.0f} s "
                        "(camera, heightmap, attention or policy node not running?)")
                self._condition.wait(min(remaining, 0.5))

    def _execute(self, primitive: Primitive):
        timeout = float(self._param("motion_timeout"))
        if not self._driver.wait_for_server(timeout_sec=float(self._param("service_timeout"))):
            raise EpisodeAborted("node_lost: driver action /ur5/execute_primitive not available")
        done = threading.Event()
        goal_future = self._driver.send_goal_async(ExecutePrimitive.Goal(primitive=primitive))
        goal_future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout):
            raise EpisodeAborted("node_lost: driver did not answer the goal")
        handle = goal_future.result()
        if not handle.accepted:
            raise EpisodeAborted("error: driver rejected the primitive")
        done.clear()
        result_future = handle.get_result_async()
        result_future.add_done_callback(lambda _: done.set())
        deadline = time.monotonic() + timeout
        while not done.wait(1.0):
            if time.monotonic() > deadline or not self._driver.server_is_ready():
                raise EpisodeAborted(f"node_lost: driver did not finish the motion "
                                     f"({'timeout' if time.monotonic() > deadline else 'server gone'})")
        return result_future.result().result

    # ---- outputs ------------------------------------------------------------------------------
    def _publish_step(self, episode_id, step: StepRecord, primitive, outcome, goal_handle) -> None:
        msg = EpisodeStep(episode_id=episode_id, step=step.step, attention_mode=step.attention_mode,
                          primitive=primitive, success=step.success, target_grasped=step.target_grasped,
                          targets_remaining=step.targets_remaining, motion_finished=outcome.finished)
        self._steps_pub.publish(msg)
        if goal_handle is not None:
            goal_handle.publish_feedback(RunEpisode.Feedback(step=msg))

    def _save_first_view(self, directory: pathlib.Path, attention: AttentionResult) -> None:
        try:
            color = image_to_numpy(attention.heightmap.color, {"rgb8"})
            cv2.imwrite(str(directory / "first_heightmap.png"), color[:, :, ::-1])
        except ValueError as error:
            self.get_logger().warning(f"first heightmap not saved: {error}")

    def _save_picture(self, directory: pathlib.Path) -> None:
        first = directory / "first_heightmap.png"
        if not first.exists():
            return
        steps = [r for r in read_steps(directory / "steps.jsonl") if r.get("event") == "step"]
        picture = draw_episode(cv2.imread(str(first))[:, :, ::-1], steps)
        cv2.imwrite(str(directory / "episode.png"), picture[:, :, ::-1])


def _step_record(step_index, attention, primitive, outcome, remaining) -> StepRecord:
    return StepRecord(
        step=step_index, attention_mode=MODE_NAMES.get(attention.mode, str(attention.mode)),
        kind="grasp" if primitive.kind == Primitive.GRASP else "push",
        position=(primitive.position.x, primitive.position.y, primitive.position.z),
        yaw=float(primitive.yaw), q_value=float(primitive.q_value),
        rotation_index=int(primitive.rotation_index),
        pixel=(int(primitive.pixel_row), int(primitive.pixel_col)),
        decision_stamp_ns=time_to_ns(primitive.header.stamp),
        motion_finished_ns=time_to_ns(outcome.finished),
        success=bool(outcome.success), target_grasped=bool(outcome.target_grasped),
        object_grasped=bool(outcome.success and primitive.kind == Primitive.GRASP),
        targets_remaining=remaining, message=outcome.message)


def _new_episode_id() -> str:
    return time.strftime("%Y%m%d-%H%M%S-") + uuid.uuid4().hex[:6]



def main(args=None):
    spin_node(EpisodeNode, args=args, executor_factory=lambda: MultiThreadedExecutor(num_threads=4))


if __name__ == "__main__":
    main()
