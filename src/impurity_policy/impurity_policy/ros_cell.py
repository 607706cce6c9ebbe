"""The node graph as a cell of the picking loop (core/picking.py): ROS clients behind its five verbs.

    reset            /cell/reset_scene (simulated cells; without it, the request's target count)
    observe          the first decision on /policy/primitive, with its /attention/result, from a camera
                     frame stamped after the last motion finished (or a NONE attention result)
    decide           that decision as a picking.Action
    execute          the /ur5/execute_primitive action, waited for with timeouts
    targets_remaining  /cell/ground_truth (simulated cells), else what the driver reported

Every wait is bounded; a node that does not answer ends the episode with EpisodeAborted("node_lost: ...").
The episode node owns one RosCell; its callbacks run in the node's executor threads.
"""

from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass

from rclpy.action import ActionClient
from rclpy.qos import QoSProfile, ReliabilityPolicy

from impurity_common import names
from impurity_common.conversions import image_to_numpy, time_to_ns
from impurity_interfaces.action import ExecutePrimitive
from impurity_interfaces.msg import AttentionResult, Primitive
from impurity_interfaces.srv import GetGroundTruth, ResetScene
from impurity_policy.core.episode import EpisodeRequest
from impurity_policy.core.picking import Action, EpisodeAborted, Outcome, View

POLICY_GONE_GRACE = 5.0  # s without the policy node's publisher, once it had been seen, before giving up
ATTENTION_KEPT = 20  # attention results kept to pair with decisions (by stamp)


@dataclass(frozen=True)
class RosCellTimeouts:
    decision: float = 30.0  # s to wait for a fresh decision
    motion: float = 120.0  # s for the driver to finish a motion
    service: float = 30.0  # s for a service or an action server to answer


class RosCell:
    """Cell adapter over ROS clients (see the module docstring). use_ground_truth: a simulated cell
    resets scenes and counts targets with its services."""

    def __init__(self, node, callback_group, timeouts: RosCellTimeouts, use_ground_truth: bool = True):
        self.node, self.timeouts, self.use_ground_truth = node, timeouts, use_ground_truth
        self._condition = threading.Condition()
        self._attention_by_stamp: collections.OrderedDict[int, AttentionResult] = collections.OrderedDict()
        self._latest_primitive: Primitive | None = None
        self._policy_seen = False
        self._after_ns = 0  # views must come from frames stamped after this (the last motion's end)
        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(AttentionResult, names.ATTENTION_TOPIC, self._on_attention, reliable,
                                 callback_group=callback_group)
        node.create_subscription(Primitive, names.PRIMITIVE_TOPIC, self._on_primitive, reliable,
                                 callback_group=callback_group)
        self._driver = ActionClient(node, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION,
                                    callback_group=callback_group)
        self._reset = node.create_client(ResetScene, names.RESET_SCENE_SERVICE, callback_group=callback_group)
        self._ground_truth = node.create_client(GetGroundTruth, names.GROUND_TRUTH_SERVICE,
                                                callback_group=callback_group)
        self.last_primitive: Primitive | None = None  # the message of the action under way
        self.last_finished = None  # builtin_interfaces/Time of the last motion's end

    # ---- inputs -------------------------------------------------------------------------------
    def _on_attention(self, msg: AttentionResult) -> None:
        with self._condition:
            self._attention_by_stamp[time_to_ns(msg.header.stamp)] = msg
            while len(self._attention_by_stamp) > ATTENTION_KEPT:
                self._attention_by_stamp.popitem(last=False)
            self._condition.notify_all()

    def _on_primitive(self, msg: Primitive) -> None:
        with self._condition:
            self._latest_primitive = msg
            self._condition.notify_all()

    # ---- the cell's verbs ---------------------------------------------------------------------
    def reset(self, request: EpisodeRequest) -> int:
        """Targets in the scene: from /cell/reset_scene on a simulated cell, else the request's."""
        self._after_ns = self.node.get_clock().now().nanoseconds
        if not self.use_ground_truth:
            return request.num_targets
        response = self._call(self._reset, ResetScene.Request(
            scenario=request.scenario, seed=request.seed, num_targets=request.num_targets,
            num_objects=request.num_objects, scene_file=request.scene_file), names.RESET_SCENE_SERVICE)
        if not response.success:
            raise EpisodeAborted(f"error: scene reset failed: {response.message}")
        self._after_ns = self.node.get_clock().now().nanoseconds
        return int(response.num_targets)

    def observe(self) -> View:
        """The first decision (and its attention result) from a frame stamped after the last motion,
        or a NONE attention result from such a frame."""
        attention, primitive = self._fresh_decision(self._after_ns)
        return View(int(attention.mode), self._color(attention), (attention, primitive))

    def decide(self, view: View) -> Action | None:
        attention, primitive = view.source
        if primitive is None:
            return None
        return Action(kind="grasp" if primitive.kind == Primitive.GRASP else "push",
                      position=(primitive.position.x, primitive.position.y, primitive.position.z),
                      yaw=float(primitive.yaw), q_value=float(primitive.q_value),
                      rotation_index=int(primitive.rotation_index),
                      pixel=(int(primitive.pixel_row), int(primitive.pixel_col)), mode=int(attention.mode),
                      decision_stamp_ns=time_to_ns(primitive.header.stamp), source=primitive)

    def execute(self, action: Action) -> Outcome:
        result = self._execute(action.source)
        self.last_primitive, self.last_finished = action.source, result.finished
        self._after_ns = time_to_ns(result.finished)
        return Outcome(bool(result.success), bool(result.target_grasped), result.message,
                       time_to_ns(result.finished))

    def targets_remaining(self, outcome: Outcome, before: int) -> int:
        if self.use_ground_truth:
            return int(self._call(self._ground_truth, GetGroundTruth.Request(),
                                  names.GROUND_TRUTH_SERVICE).targets_remaining)
        return before - (1 if outcome.target_grasped else 0)

    # ---- waits --------------------------------------------------------------------------------
    def _color(self, attention: AttentionResult):
        try:
            return image_to_numpy(attention.heightmap.color, {"rgb8"})
        except ValueError as error:
            self.node.get_logger().warning(f"colour heightmap not usable for the episode picture: {error}")
            return None

    def _call(self, client, request, name: str):
        timeout = self.timeouts.service
        if not client.wait_for_service(timeout_sec=timeout):
            raise EpisodeAborted(f"node_lost: service {name} not available within {timeout:.0f} s")
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout):
            raise EpisodeAborted(f"node_lost: no response from {name} within {timeout:.0f} s")
        return future.result()

    def _fresh_decision(self, after_ns: int):
        """(attention, primitive) of the first decision from a frame stamped after `after_ns`, or
        (NONE attention, None)."""
        timeout = self.timeouts.decision
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
                if self.node.count_publishers(names.PRIMITIVE_TOPIC) > 0:
                    self._policy_seen, gone_since = True, None
                elif self._policy_seen:  # it was there and left; a slow start is the decision timeout's job
                    gone_since = gone_since or time.monotonic()
                    if time.monotonic() - gone_since > POLICY_GONE_GRACE:
                        raise EpisodeAborted(f"node_lost: the policy node left {names.PRIMITIVE_TOPIC}")
                if remaining <= 0:
                    raise EpisodeAborted(
                        f"node_lost: no fresh decision on {names.PRIMITIVE_TOPIC} within {timeout:.0f} s "
                        "(camera, heightmap, attention or policy node not running?)")
                self._condition.wait(min(remaining, 0.5))

    def _execute(self, primitive: Primitive):
        timeout = self.timeouts.motion
        if not self._driver.wait_for_server(timeout_sec=self.timeouts.service):
            raise EpisodeAborted(f"node_lost: driver action {names.EXECUTE_PRIMITIVE_ACTION} not available")
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
