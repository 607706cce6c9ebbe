"""The node graph as a cell of the picking loop (core/picking.py): ROS clients behind its verbs.

    reset            use_ground_truth: /cell/reset_scene builds the scene and counts its targets.
                     Without (a real cell): no count (None: the loop counts by perception); scenario and
                     seed apply only if a simulated cell offers /cell/reset_scene within
                     scene_service_wait s, and its counts are not handed to the loop
    observe          the first decision on /policy/primitive, with its /attention/result, from a camera
                     frame stamped after the last motion finished and after the last view (or a NONE
                     attention result); the view holds the heightmap and the attended target's mask
    decide           that decision as a picking.Action
    execute          the /ur5/execute_primitive action, waited for with timeouts; a driver that lost
                     the arm (result message "driver_lost: ...") ends the episode with that reason
    targets_remaining  /cell/ground_truth (use_ground_truth only: in and outside the workspace)
    truth            without use_ground_truth, /cell/ground_truth where a simulated cell offers it: only
                     recorded beside the perception verdicts (None on a real cell)
    know_product     the view's heightmap on /attention/known_product (transient local) for the attention
                     node; an empty heightmap clears it: at the episode's end (know_product(None)) and
                     first thing in each reset
    look_closer      the loop's stall look: /attention/look_closer set true, the first decision from a
                     frame stamped after attention answered (attended as a stall look), then set false;
                     None (logged) when attention does not offer it or declines

Every wait is bounded; a node that does not answer ends the episode with EpisodeAborted("node_lost: ...").
Inputs stamped on another clock than this node's (a camera on its device clock, use_sim_time on some
nodes only) end it with "stale_input: ..." naming the gap, measured on the attention results it hears.
Camera frames the heightmap node drops as unusable (/heightmap/dropped: depth units, a camera pose that does
not fit the table), UNUSABLE_FRAMES in a row with no attention result between them while a view is awaited,
end it with "unusable_input: ..." and the node's reason.
Every wait also polls the loop's should_stop (set_should_stop) at least every CANCEL_POLL s and raises
picking.EpisodeCanceled; a cancel during a motion is forwarded to the driver, whose result (the motion
stopped) is still awaited so that the step is recorded and the arm is parked before the episode ends.
The episode node owns one RosCell; its callbacks run in the node's executor threads.
"""

from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from std_srvs.srv import SetBool

from impurity_common import names
from impurity_common.clients import RaceFreeActionClient
from impurity_common.conversions import image_to_numpy, time_to_ns
from impurity_common.parameters import param
from impurity_interfaces.action import ExecutePrimitive
from impurity_interfaces.msg import AttentionResult, Heightmap, Primitive
from impurity_interfaces.srv import GetGroundTruth, ResetScene
from impurity_policy.core.episode import EpisodeRequest
from impurity_policy.core.picking import (
    Action,
    EpisodeAborted,
    EpisodeCanceled,
    Outcome,
    Targets,
    Truth,
    View,
)
from impurity_policy.core.verdict import full_mask

POLICY_GONE_GRACE = 5.0  # s without the policy node's publisher, once it had been seen, before giving up
ATTENTION_KEPT = 20  # attention results kept to pair with decisions (by stamp)
LOOK_CLOSER_WAIT, LOOK_CLOSER_TRIES = 2.0, 3  # s per try, tries: a stall look is given up, not the episode
CANCEL_POLL = 0.1  # s between two looks at should_stop in every wait (a cancel is honoured within it)
# s: attention results stamped further ahead of this node's clock are not taken as fresh (a frame taken
# before the last motion would pass as taken after it); their stamps are on another clock.
MAX_STAMP_LEAD = 1.0
# s: when no decision came although attention results did, results stamped more than this before this
# node's clock (at receipt) make the reason "stale_input" (the policy node refuses them: its max_age).
STALE_GAP = 2.0
ATTENTION_SILENT = 5.0  # s without attention results at the decision timeout: their stream stopped
# Frames dropped as unusable in a row, no attention result between them, that end the episode: as many as
# the NONE answers that end it by perception (core/episode.py), so that one odd frame does not.
UNUSABLE_FRAMES = 3
CLOCK_HINT = "camera clock? use_sim_time / the driver's timestamp setting"


@dataclass(frozen=True)
class RosCellTimeouts:
    """How long the cell's waits last; the episode node's parameters of the same names."""

    decision_timeout: float = param(30.0, "s to wait for a fresh decision before giving up (node_lost, or "
                                    "stale_input when the attention results are stamped on another clock)",
                                    low=0.1)
    motion_timeout: float = param(120.0, "s to wait for the driver to finish a motion", low=0.1)
    service_timeout: float = param(30.0, "s to wait for a service or an action server (reset, ground truth)",
                                   low=0.1)
    scene_service_timeout: float = param(3.0, "Without ground truth: s to wait for a simulated cell's "
                                         "/cell/reset_scene and /cell/ground_truth (a real cell has neither; "
                                         "0: never ask)", low=0.0)


class RosCell:
    """Cell adapter over ROS clients (see the module docstring). use_ground_truth: a simulated cell
    resets scenes and counts targets with its services; False: the loop counts by perception."""

    def __init__(self, node, callback_group, timeouts: RosCellTimeouts, use_ground_truth: bool = True):
        self.node, self.timeouts, self.use_ground_truth = node, timeouts, use_ground_truth
        self._condition = threading.Condition()
        self._attention_by_stamp: collections.OrderedDict[int, AttentionResult] = collections.OrderedDict()
        self._latest_primitive: Primitive | None = None
        self._policy_seen = False
        self._after_ns = 0  # views must come from frames stamped after this (the last motion's end)
        self._after_what = "the scene reset"  # what _after_ns is, for messages
        # (received ns on this node's clock, stamp ns) of the last attention results: the stamp gap
        self._attention_heard: collections.deque[tuple[int, int]] = collections.deque(maxlen=ATTENTION_KEPT)
        self._should_stop = None  # the loop's cancel check, polled in every wait
        # (received ns on this node's clock, reason) of the frames dropped since the last attention result
        self._unusable: collections.deque[tuple[int, str]] = collections.deque(maxlen=ATTENTION_KEPT)
        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(AttentionResult, names.ATTENTION_TOPIC, self._on_attention, reliable,
                                 callback_group=callback_group)
        node.create_subscription(Primitive, names.PRIMITIVE_TOPIC, self._on_primitive, reliable,
                                 callback_group=callback_group)
        node.create_subscription(String, names.HEIGHTMAP_DROPPED_TOPIC, self._on_dropped, 10,
                                 callback_group=callback_group)
        self._driver = RaceFreeActionClient(node, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION,
                                            callback_group=callback_group)
        self._reset = node.create_client(ResetScene, names.RESET_SCENE_SERVICE, callback_group=callback_group)
        self._ground_truth = node.create_client(GetGroundTruth, names.GROUND_TRUTH_SERVICE,
                                                callback_group=callback_group)
        self._known_product = node.create_publisher(
            Heightmap, names.KNOWN_PRODUCT_TOPIC,
            QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self._look_closer = node.create_client(SetBool, names.LOOK_CLOSER_SERVICE,
                                               callback_group=callback_group)
        self._truth_offered = False  # without use_ground_truth: a simulated cell's truth, for the records
        self.last_primitive: Primitive | None = None  # the message of the action under way
        self.last_finished = None  # builtin_interfaces/Time of the last motion's end

    # ---- inputs -------------------------------------------------------------------------------
    def _on_attention(self, msg: AttentionResult) -> None:
        with self._condition:
            stamp_ns = time_to_ns(msg.header.stamp)
            self._attention_heard.append((self.node.get_clock().now().nanoseconds, stamp_ns))
            self._attention_by_stamp[stamp_ns] = msg
            self._unusable.clear()
            while len(self._attention_by_stamp) > ATTENTION_KEPT:
                self._attention_by_stamp.popitem(last=False)
            self._condition.notify_all()

    def _on_dropped(self, msg: String) -> None:
        with self._condition:
            self._unusable.append((self.node.get_clock().now().nanoseconds, msg.data))
            self._condition.notify_all()

    def _on_primitive(self, msg: Primitive) -> None:
        with self._condition:
            self._latest_primitive = msg
            self._condition.notify_all()

    # ---- the cell's verbs ---------------------------------------------------------------------
    def set_should_stop(self, should_stop) -> None:
        """The loop's cancel check (None: none), polled in every wait of the verbs below."""
        self._should_stop = should_stop

    def reset(self, request: EpisodeRequest) -> Targets | None:
        """Targets in the scene from /cell/reset_scene (in and outside the workspace) with
        use_ground_truth; else None (see the module docstring). Clears the known product first."""
        self.know_product(None)
        self._after_ns = self.node.get_clock().now().nanoseconds
        self._after_what = "the scene reset"
        if not self.use_ground_truth:
            self._reset_if_simulated(request)
            return None
        response = self._call(self._reset, ResetScene.Request(
            scenario=request.scenario, seed=request.seed, num_targets=request.num_targets,
            num_objects=request.num_objects, scene_file=request.scene_file, palette=request.palette),
            names.RESET_SCENE_SERVICE)
        if not response.success:
            raise EpisodeAborted(f"error: scene reset failed: {response.message}")
        self._after_ns = self.node.get_clock().now().nanoseconds
        outside = int(response.targets_outside_workspace)
        if outside:
            self.node.get_logger().warning(
                f"{outside} of the scene's {response.num_targets} target(s) lie outside the workspace: "
                "counted apart, they cannot be picked")
        return Targets(int(response.num_targets) - outside, outside)

    def _reset_if_simulated(self, request: EpisodeRequest) -> None:
        """Without use_ground_truth: build the request's scene if a simulated cell offers
        /cell/reset_scene (its counts stay here), and note whether it offers /cell/ground_truth."""
        wait = self.timeouts.scene_service_timeout
        offered = wait > 0 and self._wait_until(
            lambda: self._reset.service_is_ready() or self._ground_truth.service_is_ready(), wait,
            f"service {self._name(names.RESET_SCENE_SERVICE)} or {self._name(names.GROUND_TRUTH_SERVICE)}")
        self._truth_offered = offered and self._ground_truth.service_is_ready()
        if not (offered and self._reset.service_is_ready()):
            self.node.get_logger().info(f"no {self._name(names.RESET_SCENE_SERVICE)}: the episode starts on "
                                        "the cell as it is (scenario and seed apply to simulated cells only)")
            return
        response = self._call(self._reset, ResetScene.Request(
            scenario=request.scenario, seed=request.seed, num_targets=request.num_targets,
            num_objects=request.num_objects, scene_file=request.scene_file, palette=request.palette),
            names.RESET_SCENE_SERVICE)
        if not response.success:
            raise EpisodeAborted(f"error: scene reset failed: {response.message}")
        self._after_ns = self.node.get_clock().now().nanoseconds

    def truth(self) -> Truth | None:
        """The simulator's truth without use_ground_truth, for the records only; None on a real cell or
        when it does not answer (logged)."""
        if self.use_ground_truth or not self._truth_offered:
            return None
        try:
            truth = self._call(self._ground_truth, GetGroundTruth.Request(), names.GROUND_TRUTH_SERVICE)
        except EpisodeAborted as error:
            self.node.get_logger().warning(f"ground truth for the records not available: {error}")
            return None
        if not truth.success:
            self.node.get_logger().warning(f"ground truth for the records not available: {truth.message}")
            return None
        return Truth(int(truth.targets_remaining), int(truth.targets_outside_workspace),
                     int(truth.targets_removed))

    def know_product(self, view: View | None) -> None:
        """The loop's word that `view` (one of this cell's) shows product only: its heightmap goes to the
        attention node as the known product (/attention/known_product), which attends the following frames
        with it until the next reset clears it; None (the episode ended) clears it at once."""
        if view is None:
            cleared = Heightmap()
            cleared.header.stamp = self.node.get_clock().now().to_msg()
            self._known_product.publish(cleared)
            return
        attention, _ = view.source
        self._known_product.publish(attention.heightmap)
        stamp = time_to_ns(attention.heightmap.header.stamp)
        self.node.get_logger().info(f"known product: the first view (stamp {stamp} ns) showed no target; "
                                    f"sent on {self._name(names.KNOWN_PRODUCT_TOPIC)}")

    def look_closer(self) -> View | None:
        """The loop's stall look (core/picking.py): attention attends the frames that follow as a stall look
        (/attention/look_closer true); the view is the first decision from a frame stamped after it said
        so; the look is then switched off. None, with a warning, when attention offers no such service or
        declines (its reason)."""
        response = self._ask_look_closer(True)
        if response is None or not response.success:
            why = "no answer" if response is None else response.message
            self.node.get_logger().warning(f"no stall look: {why}; deciding on the last view")
            return None
        try:
            self._after_ns = max(self._after_ns, self.node.get_clock().now().nanoseconds)
            self._after_what = "the stall look's request"
            return self.observe()
        finally:
            if self._ask_look_closer(False) is None:
                self.node.get_logger().warning(f"stall look not switched off: no answer from "
                                               f"{self._name(names.LOOK_CLOSER_SERVICE)}")

    def _ask_look_closer(self, on: bool):
        """/attention/look_closer's answer to `on`, or None when the service is not offered or does not
        answer within LOOK_CLOSER_TRIES x LOOK_CLOSER_WAIT s (the request is idempotent: sent again while
        unanswered); a cancel while waiting raises EpisodeCanceled."""
        if not self._look_closer.service_is_ready():
            return None
        for _ in range(LOOK_CLOSER_TRIES):
            response = self._request(self._look_closer, SetBool.Request(data=on), names.LOOK_CLOSER_SERVICE,
                                     LOOK_CLOSER_WAIT)
            if response is not None:
                return response
        return None

    def observe(self) -> View:
        """The first decision (and its attention result) from a frame stamped after the last motion and
        the last view, or a NONE attention result from such a frame."""
        attention, primitive = self._fresh_decision(self._after_ns)
        self._after_ns = max(self._after_ns, time_to_ns(attention.header.stamp))
        self._after_what = "the last view"
        color = self._color(attention)
        height, mask = self._height_and_mask(attention, color)
        heap = float(attention.score) if attention.mode == AttentionResult.MODE_OCCLUDED_REGION else 0.0
        return View(int(attention.mode), color, (attention, primitive), height, mask, float(attention.score),
                    bool(attention.last_look), heap_height=heap)

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
        """Run the primitive on the driver; EpisodeAborted("driver_lost: ...") when the driver lost the arm.
        Without use_ground_truth the simulator-only target_grasped is not passed on."""
        result = self._execute(action.source)
        self.last_primitive, self.last_finished = action.source, result.finished
        if result.message.startswith("driver_lost"):
            raise EpisodeAborted(result.message)
        self._after_ns = time_to_ns(result.finished)
        self._after_what = "the last motion's end as the driver stamped it: driver clock?"
        return Outcome(bool(result.success), bool(result.target_grasped) and self.use_ground_truth,
                       result.message, time_to_ns(result.finished), bool(result.motion_completed),
                       float(result.gripper_opening), bool(result.holding))

    def targets_remaining(self, outcome: Outcome, before: int) -> Targets:
        if self.use_ground_truth:
            truth = self._call(self._ground_truth, GetGroundTruth.Request(), names.GROUND_TRUTH_SERVICE)
            if not truth.success:
                raise EpisodeAborted(f"error: ground truth not available: {truth.message}")
            return Targets(int(truth.targets_remaining), int(truth.targets_outside_workspace))
        return Targets(before - (1 if outcome.target_grasped else 0))  # not asked when counting by perception

    # ---- waits --------------------------------------------------------------------------------
    def _color(self, attention: AttentionResult):
        try:
            return image_to_numpy(attention.heightmap.color, {"rgb8"})
        except ValueError as error:
            self.node.get_logger().warning(f"colour heightmap not usable for the episode picture: {error}")
            return None

    def _height_and_mask(self, attention: AttentionResult, color):
        """The view's height map (H, W) m and, for TARGET, the attended target's mask placed in the full
        map; (None, None) when the heightmap is not usable (logged)."""
        try:
            height = image_to_numpy(attention.heightmap.height, {"32FC1"})
        except ValueError as error:
            self.node.get_logger().warning(f"height map not usable to judge grasps: {error}")
            return None, None
        if attention.mode != AttentionResult.MODE_TARGET or color is None:
            return height, None
        try:
            crop = image_to_numpy(attention.mask, {"mono8"})
        except ValueError as error:
            self.node.get_logger().warning(f"target mask not usable to judge grasps: {error}")
            return height, None
        mask = full_mask(crop > 0, (attention.crop_row0, attention.crop_col0), height.shape)
        return height, (mask if mask.any() else None)

    def _check_cancel(self, what: str) -> None:
        """EpisodeCanceled when the loop's should_stop says so."""
        if self._should_stop is not None and self._should_stop():
            raise EpisodeCanceled(f"canceled while waiting for {what}")

    def _wait_until(self, ready, timeout: float, what: str) -> bool:
        """Poll ready() every CANCEL_POLL s for up to `timeout` s: True when it is, False at the timeout,
        EpisodeCanceled on a cancel."""
        deadline = time.monotonic() + timeout
        pause = threading.Event()
        while not ready():
            self._check_cancel(what)
            if time.monotonic() > deadline:
                return False
            pause.wait(CANCEL_POLL)
        return True

    def _wait_event(self, done: threading.Event, timeout: float, what: str) -> bool:
        """Wait for `done` up to `timeout` s: True when set (an answer within the first CANCEL_POLL s wins
        over a cancel), False at the timeout, EpisodeCanceled on a cancel."""
        deadline = time.monotonic() + timeout
        while not done.wait(min(CANCEL_POLL, max(deadline - time.monotonic(), 0.0))):
            self._check_cancel(what)
            if time.monotonic() > deadline:
                return False
        return True

    def _name(self, name: str) -> str:
        """A name of impurity_common.names as it resolves in the episode node's namespace (for messages)."""
        return names.absolute(name, self.node.get_namespace())

    def _call(self, client, request, name: str):
        name, timeout = self._name(name), self.timeouts.service_timeout
        if not self._wait_until(client.service_is_ready, timeout, f"service {name}"):
            raise EpisodeAborted(f"node_lost: service {name} not available within {timeout:.0f} s")
        response = self._request(client, request, name, timeout)
        if response is None:
            raise EpisodeAborted(f"node_lost: no response from {name} within {timeout:.0f} s")
        return response

    def _request(self, client, request, name: str, timeout: float):
        """One request to a ready service: its response, or None (the request withdrawn) when none came
        within `timeout` s; a cancel while waiting withdraws it and raises EpisodeCanceled."""
        name = self._name(name)
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        try:
            answered = self._wait_event(done, timeout, f"a response from {name}")
        except EpisodeCanceled:
            client.remove_pending_request(future)
            raise
        if not answered:
            client.remove_pending_request(future)
            return None
        return future.result()

    def _fresh_decision(self, after_ns: int):
        """(attention, primitive) of the first decision from a frame stamped after `after_ns`, or
        (NONE attention, None)."""
        timeout = self.timeouts.decision_timeout
        deadline = time.monotonic() + timeout
        waiting_since_ns = self.node.get_clock().now().nanoseconds
        gone_since = None
        with self._condition:
            while True:
                lead_limit = self.node.get_clock().now().nanoseconds + int(MAX_STAMP_LEAD * 1e9)
                primitive = self._latest_primitive
                if primitive is not None and after_ns < time_to_ns(primitive.header.stamp) <= lead_limit:
                    attention = self._attention_by_stamp.get(time_to_ns(primitive.header.stamp))
                    if attention is not None:
                        return attention, primitive
                newest = next(reversed(self._attention_by_stamp.values()), None)
                if (newest is not None and after_ns < time_to_ns(newest.header.stamp) <= lead_limit
                        and newest.mode == AttentionResult.MODE_NONE):
                    return newest, None
                dropped = [reason for received, reason in self._unusable if received >= waiting_since_ns]
                if len(dropped) >= UNUSABLE_FRAMES:
                    topic = self._name(names.HEIGHTMAP_DROPPED_TOPIC)
                    raise EpisodeAborted(f"unusable_input: the heightmap node dropped {len(dropped)} camera "
                                         f"frames in a row ({topic}): {dropped[-1]}")
                self._check_cancel(f"a fresh decision on {self._name(names.PRIMITIVE_TOPIC)}")
                remaining = deadline - time.monotonic()
                if self.node.count_publishers(names.PRIMITIVE_TOPIC) > 0:
                    self._policy_seen, gone_since = True, None
                elif self._policy_seen:  # it was there and left; a slow start is the decision timeout's job
                    gone_since = gone_since or time.monotonic()
                    if time.monotonic() - gone_since > POLICY_GONE_GRACE:
                        raise EpisodeAborted(
                            f"node_lost: the policy node left {self._name(names.PRIMITIVE_TOPIC)}")
                if remaining <= 0:
                    raise EpisodeAborted(self._no_decision_reason(after_ns, waiting_since_ns, timeout))
                self._condition.wait(min(remaining, CANCEL_POLL))

    def _no_decision_reason(self, after_ns: int, waiting_since_ns: int, timeout: float) -> str:
        """Why no fresh decision came within `timeout`: the stamp gap of the attention results heard while
        waiting when their stamps are not on this node's clock ("stale_input: ..."), else "node_lost: ..."."""
        now_ns = self.node.get_clock().now().nanoseconds
        heard = [(got, stamp) for got, stamp in self._attention_heard if got >= waiting_since_ns]
        if not heard:
            return (f"node_lost: no fresh decision on {self._name(names.PRIMITIVE_TOPIC)} within "
                    f"{timeout:.0f} s and no attention results (camera, heightmap, attention or policy "
                    "node not running?)")
        received, stamp = heard[-1]
        if (now_ns - received) * 1e-9 > ATTENTION_SILENT:
            return (f"node_lost: attention results stopped {(now_ns - received) * 1e-9:.0f} s ago and no "
                    f"fresh decision came within {timeout:.0f} s (camera, heightmap or attention node "
                    "stopped?)")
        gap = (received - stamp) * 1e-9  # > 0: stamped before this node's clock
        if gap < -MAX_STAMP_LEAD:
            return (f"stale_input: attention results are stamped {-gap:.1f} s after this node's clock "
                    f"({CLOCK_HINT}); a frame taken before a motion could pass as taken after it")
        if gap > STALE_GAP:
            return (f"stale_input: attention results are stamped {gap:.1f} s before this node's clock "
                    f"({CLOCK_HINT}); the policy node answers none older than its max_age")
        if not any(stamp_ns > after_ns for _, stamp_ns in heard):  # on this clock, yet never after after_ns
            return (f"stale_input: attention results are stamped {(after_ns - stamp) * 1e-9:.1f} s before "
                    f"{self._after_what} (use_sim_time / the driver's timestamp setting)")
        return (f"node_lost: attention results arrive (stamped {gap:.1f} s before this node's clock) but no "
                f"decision on {self._name(names.PRIMITIVE_TOPIC)} within {timeout:.0f} s (policy node not "
                "running, or refusing them: see its log)")

    def _execute(self, primitive: Primitive):
        timeout = self.timeouts.motion_timeout
        action = self._name(names.EXECUTE_PRIMITIVE_ACTION)
        if not self._wait_until(self._driver.server_is_ready, self.timeouts.service_timeout,
                                f"driver action {action}"):
            raise EpisodeAborted(f"node_lost: driver action {action} not available")
        done = threading.Event()
        goal_future = self._driver.send_goal_async(ExecutePrimitive.Goal(primitive=primitive))
        goal_future.add_done_callback(lambda _: done.set())
        try:
            answered = self._wait_event(done, timeout, "the driver's answer to the goal")
        except EpisodeCanceled:  # the driver may still accept it: then cancel it at once
            goal_future.add_done_callback(_cancel_if_accepted)
            raise
        if not answered:
            raise EpisodeAborted("node_lost: driver did not answer the goal")
        handle = goal_future.result()
        if not handle.accepted:  # ends the episode: a refusal is not a failed attempt (cell.yaml)
            raise EpisodeAborted("error: driver rejected the primitive (its log says why)")
        done.clear()
        result_future = handle.get_result_async()
        result_future.add_done_callback(lambda _: done.set())
        deadline = time.monotonic() + timeout
        cancel_sent = False
        while not done.wait(CANCEL_POLL):
            if not cancel_sent and self._should_stop is not None and self._should_stop():
                # Stop the motion; its result (the driver opens, lifts and parks) is still awaited.
                self.node.get_logger().info("cancel: stopping the motion under way")
                handle.cancel_goal_async()
                cancel_sent = True
            if time.monotonic() > deadline or not self._driver.server_is_ready():
                raise EpisodeAborted(f"node_lost: driver did not finish the motion "
                                     f"({'timeout' if time.monotonic() > deadline else 'server gone'})")
        return result_future.result().result


def _cancel_if_accepted(goal_future) -> None:
    """Done callback of a goal whose episode was canceled before the driver answered."""
    handle = goal_future.result()
    if handle is not None and handle.accepted:
        handle.cancel_goal_async()
