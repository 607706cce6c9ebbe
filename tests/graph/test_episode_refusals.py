"""Episode node on its own: bad requests and a second start are refused with a reason, and an episode
whose cell does not answer ends with a clear reason and an intact record; against a scripted cell in
this process: a cancel in every wait, inputs stamped on another clock, a motion the driver refuses, a
scene reset the cell refuses (no folder left), two drivers on one action (refused), /episode/stop and a
node stopped mid-episode (the record closed either way)."""

import json
import os
import pathlib
import re
import signal
import threading

import pytest
import rclpy
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Point
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from impurity_common import names
from impurity_common.conversions import ns_to_time
from impurity_interfaces.action import ExecutePrimitive, RunEpisode
from impurity_interfaces.msg import AttentionResult, Primitive
from impurity_interfaces.srv import ResetScene, StartEpisode
from impurity_policy.core.episode import read_steps
from ros_harness import ActionHelper, call_service, ros_args, spin_until


def test_refusals_and_a_missing_cell(ros_node, launch, tmp_path):
    # start_wait 0.5 s: a start is answered before the 6 s wait for the missing reset service ends, so the
    # episode is still under way (busy) for the requests below
    episode = launch("impurity_policy", "episode_node",
                     ros_args({"record_dir": str(tmp_path), "service_timeout": 6.0, "start_wait": 0.5}))

    bad = call_service(ros_node, StartEpisode, "/episode/start",
                       StartEpisode.Request(scenario="moon_rocks"), processes=[episode], resend_after=5.0)
    assert not bad.accepted and "unknown scenario 'moon_rocks'" in bad.reason
    negative = call_service(ros_node, StartEpisode, "/episode/start",
                            StartEpisode.Request(num_objects=-4), processes=[episode], resend_after=5.0)
    assert not negative.accepted and "num_objects must be >= 0" in negative.reason
    # more targets than product blocks: refused on both routes, with its reason on the service's
    crowded = dict(scenario="random", num_targets=50, num_objects=5)
    too_many = call_service(ros_node, StartEpisode, "/episode/start", StartEpisode.Request(**crowded),
                            processes=[episode], resend_after=5.0)
    assert not too_many.accepted and "num_targets (50) must not exceed num_objects (5)" in too_many.reason
    assert not ActionHelper(ros_node, RunEpisode, "/episode/run", processes=[episode]).send_goal(
        RunEpisode.Goal(**crowded)).accepted
    assert not any(tmp_path.iterdir())  # no refusal made a folder

    first = call_service(ros_node, StartEpisode, "/episode/start",
                         StartEpisode.Request(scenario="random", seed=1), processes=[episode])
    assert first.accepted and first.episode_id
    second = call_service(ros_node, StartEpisode, "/episode/start",
                          StartEpisode.Request(scenario="random", seed=2), processes=[episode])
    assert not second.accepted and second.reason.startswith("busy")
    action = ActionHelper(ros_node, RunEpisode, "/episode/run", processes=[episode])
    assert not action.send_goal(RunEpisode.Goal(scenario="random")).accepted

    # No sim cell runs: the reset service never appears and the episode ends, saying why.
    summary_path = tmp_path / first.episode_id / "summary.json"
    spin_until(ros_node, summary_path.exists, 30.0, "the episode summary", [episode])
    summary = json.loads(summary_path.read_text())
    assert summary["termination_reason"].startswith("node_lost: service /cell/reset_scene")
    assert summary["actions"] == 0
    index = (tmp_path / "episodes.jsonl").read_text().splitlines()
    assert json.loads(index[-1])["episode_id"] == first.episode_id

    # Free again: a bad goal is now rejected for its own reason, a good one would be accepted.
    assert not action.send_goal(RunEpisode.Goal(scenario="file")).accepted
    # (the summary is written just before the node frees itself: a start in between is still "busy")
    retries = []
    spin_until(ros_node, lambda: retries.append(call_service(
        ros_node, StartEpisode, "/episode/start", StartEpisode.Request(scenario="random", seed=3),
        processes=[episode])) or retries[-1].accepted, 30.0, "a start accepted", [episode])
    assert all(r.reason.startswith("busy") for r in retries[:-1])
    action.destroy()


# ---- the episode node against a scripted cell in this process -------------------------------------------
class ScriptedCell:
    """Stands in for attention, policy and driver, in this test process on its own executor thread:
    publishes attention results (stamped `stamp_offset` s from this clock) and, with `decide`, a push
    decision on each; serves /ur5/execute_primitive as `driver` says: "reject" every goal, leave it
    "silent" (never answered), or "hold" the motion until it is canceled; with `reset_refusal`, serves
    /cell/reset_scene refusing every scene with that message."""

    made: list = []  # every cell made in this process: each node gets a name of its own

    def __init__(self, stamp_offset: float = 0.0, decide: bool = True, driver: str = "reject",
                 reset_refusal: str | None = None):
        self.stamp_offset, self.decide, self.driver = stamp_offset, decide, driver
        self.node = rclpy.create_node(f"scripted_cell_{os.getpid()}_{len(ScriptedCell.made)}")
        ScriptedCell.made.append(self)
        reliable = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        self._attention = self.node.create_publisher(AttentionResult, names.ATTENTION_TOPIC, reliable)
        self._primitive = self.node.create_publisher(Primitive, names.PRIMITIVE_TOPIC, reliable)
        group = ReentrantCallbackGroup()
        self.goals, self.motions, self.motion_canceled = [], [], threading.Event()
        self._release = threading.Event()  # lets a silent goal callback return at teardown
        self._server = ActionServer(self.node, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION,
                                    execute_callback=self._execute, goal_callback=self._on_goal,
                                    cancel_callback=lambda _: CancelResponse.ACCEPT, callback_group=group)
        if reset_refusal is not None:  # a simulated cell that refuses every scene, e.g. an unknown palette
            refusal = ResetScene.Response(success=False, message=reset_refusal)
            self.node.create_service(ResetScene, names.RESET_SCENE_SERVICE,
                                     lambda _request, _response: refusal, callback_group=group)
        self.node.create_timer(0.2, self._publish, callback_group=group)
        self._executor = MultiThreadedExecutor(num_threads=4)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._executor.spin, daemon=True)
        self._thread.start()

    def _publish(self) -> None:
        stamp = ns_to_time(self.node.get_clock().now().nanoseconds + int(self.stamp_offset * 1e9))
        header = Header(stamp=stamp, frame_id=names.BASE_FRAME)
        self._attention.publish(AttentionResult(header=header, mode=AttentionResult.MODE_TARGET))
        if self.decide:
            self._primitive.publish(Primitive(header=header, kind=Primitive.PUSH,
                                              position=Point(x=0.5, y=0.0, z=0.02), yaw=0.0))

    def _on_goal(self, goal) -> GoalResponse:
        self.goals.append(goal)
        if self.driver == "silent":
            self._release.wait(120.0)  # blocks this executor thread: the goal is never answered
        return GoalResponse.ACCEPT if self.driver == "hold" else GoalResponse.REJECT

    def _execute(self, goal_handle):
        self.motions.append(goal_handle)
        while not goal_handle.is_cancel_requested and not self._release.is_set():
            self._release.wait(0.05)  # the motion under way
        self.motion_canceled.set()
        goal_handle.canceled()
        return ExecutePrimitive.Result(success=False, grasped_object_id=-1, message="push cancelled",
                                       finished=self.node.get_clock().now().to_msg())

    def destroy(self) -> None:
        self._release.set()
        self._executor.shutdown(timeout_sec=5.0)
        self._thread.join(5.0)
        self._server.destroy()
        self.node.destroy_node()


@pytest.fixture
def scripted_cell():
    made = []

    def make(**kwargs) -> ScriptedCell:
        made.append(ScriptedCell(**kwargs))
        return made[-1]

    yield make
    for cell in made:
        cell.destroy()


def episode_node(launch, tmp_path, **parameters):
    """episode_node with its defaults (cell.yaml's values), records in tmp_path, no sim services (unless
    use_ground_truth)."""
    return launch("impurity_policy", "episode_node", ros_args(
        {"record_dir": str(tmp_path), "use_ground_truth": False, **parameters}))


def summary_of(result) -> dict:
    return json.loads((pathlib.Path(result.record_path) / "summary.json").read_text())


def steps_in(tmp_path) -> list:
    return [r for path in tmp_path.glob("*/steps.jsonl") for r in read_steps(path)]


@pytest.mark.parametrize("wait", ["reset service", "decision", "driver goal", "driver result"])
def test_a_cancel_is_honoured_in_every_wait_and_the_goal_ends_canceled_with_its_records(
        ros_node, launch, tmp_path, scripted_cell, wait):
    """An episode waiting (for a decision with no camera running, for a reset, for the driver) is canceled:
    the goal ends CANCELED, not ABORTED as node_lost after the timeout. Every timeout here is 120 s: a goal
    that ends within the 30 s below honoured the cancel."""
    long = 120.0
    if wait == "reset service":  # a simulated cell whose sim_cell is not running
        episode = episode_node(launch, tmp_path, use_ground_truth=True, service_timeout=long)
    else:
        episode = episode_node(launch, tmp_path, decision_timeout=long, motion_timeout=long,
                               service_timeout=long)
    cell = {"reset service": None, "decision": None,
            "driver goal": lambda: scripted_cell(driver="silent"),
            "driver result": lambda: scripted_cell(driver="hold")}[wait]
    cell = cell() if cell else None
    action = ActionHelper(ros_node, RunEpisode, "/episode/run", processes=[episode])
    handle = action.send_goal(RunEpisode.Goal(scenario="random", seed=1))
    assert handle.accepted
    waiting = {  # evidence that the episode is in that wait
        "reset service": lambda: any(path.is_dir() for path in tmp_path.iterdir()),
        "decision": lambda: any(r["event"] == "start" for r in steps_in(tmp_path)),
        "driver goal": lambda: cell.goals,
        "driver result": lambda: cell.motions,
    }[wait]
    spin_until(ros_node, waiting, 60.0, f"the episode waiting for the {wait}", [episode])
    action.cancel(handle)
    wrapped = action.get_result(handle, timeout=30.0)
    assert wrapped.status == GoalStatus.STATUS_CANCELED
    result = wrapped.result
    assert result.termination_reason == "canceled"
    assert summary_of(result)["termination_reason"] == "canceled"  # the records are closed
    steps = [r for r in read_steps(pathlib.Path(result.record_path) / "steps.jsonl") if r["event"] == "step"]
    if wait == "driver result":  # the motion was stopped by the driver, and recorded
        assert cell.motion_canceled.is_set()
        assert result.actions == len(steps) == 1 and steps[0]["message"] == "push cancelled"
    else:
        assert result.actions == len(steps) == 0
    if wait == "reset service":  # the scene was never ready: nothing was counted, and the record says so
        assert result.counted_by == summary_of(result)["counted_by"] == "nothing"
        assert result.targets_total == summary_of(result)["targets_total"] == -1
    # Free again: the next goal is accepted.
    again = action.send_goal(RunEpisode.Goal(scenario="random", seed=2))
    assert again.accepted
    action.cancel(again)
    assert action.get_result(again, timeout=30.0).status == GoalStatus.STATUS_CANCELED
    action.destroy()


@pytest.mark.parametrize("offset, decide, side", [
    (-1000.0, False, "before"),  # the policy node refuses them as stale (max_age): no decision comes
    (1000.0, True, "after"),  # the policy answers, but such a frame could predate the last motion
])
def test_attention_stamped_on_another_clock_ends_the_episode_naming_the_stamp_gap(
        ros_node, launch, tmp_path, scripted_cell, offset, decide, side):
    """Frames stamped on the camera's own clock, 1000 s off the nodes': the episode ends stale_input,
    naming the gap, not node_lost."""
    episode = episode_node(launch, tmp_path, decision_timeout=3.0)
    scripted_cell(stamp_offset=offset, decide=decide, driver="hold")
    action = ActionHelper(ros_node, RunEpisode, "/episode/run", processes=[episode])
    handle, wrapped = action.run(RunEpisode.Goal(scenario="random", seed=1), timeout=60.0)
    assert handle.accepted and wrapped.status == GoalStatus.STATUS_ABORTED
    reason = wrapped.result.termination_reason
    gap = re.fullmatch(rf"stale_input: attention results are stamped ([0-9.]+) s {side} this node's clock "
                       r"\(camera clock\? use_sim_time / the driver's timestamp setting\); .*", reason)
    assert gap is not None, reason
    assert 990.0 < float(gap.group(1)) < 1010.0  # the offset, give or take this host's latency
    assert wrapped.result.actions == 0  # nothing was executed on such a decision
    assert summary_of(wrapped.result)["termination_reason"] == reason
    action.destroy()


def test_a_motion_the_driver_refuses_ends_the_episode_at_the_first_refusal(
        ros_node, launch, tmp_path, scripted_cell):
    """A motion the driver refuses is not one of max_consecutive_failures (5 here): the first refusal ends
    the episode, as cell.yaml says."""
    episode = episode_node(launch, tmp_path, max_consecutive_failures=5)
    cell = scripted_cell(driver="reject")
    action = ActionHelper(ros_node, RunEpisode, "/episode/run", processes=[episode])
    handle, wrapped = action.run(RunEpisode.Goal(scenario="random", seed=1), timeout=60.0)
    assert handle.accepted and wrapped.status == GoalStatus.STATUS_ABORTED
    assert wrapped.result.termination_reason.startswith("error: driver rejected the primitive")
    assert wrapped.result.actions == 0 and len(cell.goals) == 1
    action.destroy()


# ---- refusals leave no traces, two drivers, stopping an episode -------------------------------------------
def test_a_start_the_cell_refuses_at_its_scene_reset_leaves_no_folder(ros_node, launch, tmp_path,
                                                                        scripted_cell):
    """A start refused at the scene reset (an unknown palette) leaves no folder under runs/episodes/: the
    refusal stays in the answer, the node's log and the index (episodes.jsonl)."""
    episode = episode_node(launch, tmp_path, use_ground_truth=True)
    scripted_cell(reset_refusal="unknown palette 'teal'; known: blocks, coal_slate")
    refused = call_service(ros_node, StartEpisode, "/episode/start",
                           StartEpisode.Request(scenario="random", seed=1, palette="teal"),
                           processes=[episode])
    assert not refused.accepted and "unknown palette 'teal'" in refused.reason
    assert [path.name for path in tmp_path.iterdir()] == ["episodes.jsonl"]
    index = read_steps(tmp_path / "episodes.jsonl")
    assert index[-1]["episode_id"] == refused.episode_id
    assert "unknown palette" in index[-1]["termination_reason"]
    spin_until(ros_node, lambda: f"start refused: episode {refused.episode_id}" in episode.output(), 10.0,
               "the refusal in the node's log", [episode])


def trigger(ros_node, name: str, episode):
    return call_service(ros_node, Trigger, name, Trigger.Request(), processes=[episode], timeout=60.0)


def test_two_drivers_on_the_arms_action_refuse_every_episode(ros_node, launch, tmp_path, scripted_cell):
    """A sim_cell run with `-r /ur5/execute_primitive:=...` beside the real driver still served the action
    (ros2/ros2#1312): both executed every primitive. The episode node refuses to start while two serve it."""
    episode = episode_node(launch, tmp_path, decision_timeout=60.0)
    scripted_cell(driver="hold")
    scripted_cell(driver="hold")
    statuses = []
    spin_until(ros_node, lambda: statuses.append(trigger(ros_node, names.EPISODE_STATUS_SERVICE, episode))
               or not statuses[-1].success, 30.0, "the episode node counting two drivers", [episode])
    assert statuses[-1].message.startswith("2 action servers serve /ur5/execute_primitive")
    start = call_service(ros_node, StartEpisode, "/episode/start", StartEpisode.Request(scenario="random"),
                         processes=[episode])
    assert not start.accepted and start.reason == statuses[-1].message
    action = ActionHelper(ros_node, RunEpisode, "/episode/run", processes=[episode])
    assert not action.send_goal(RunEpisode.Goal(scenario="random")).accepted
    action.destroy()
    assert not any(tmp_path.iterdir())
    spin_until(ros_node, lambda: "start refused: 2 action servers serve" in episode.output(), 10.0,
               "the refusal in the node's log", [episode])


@pytest.mark.parametrize("wait", ["decision", "motion"])
def test_episode_stop_ends_a_started_episode_canceled_with_its_records(ros_node, launch, tmp_path,
                                                                       scripted_cell, wait):
    """An episode started with /episode/start could not be stopped but by stopping the cell, which left
    its record without an end. /episode/stop ends it as a cancel of /episode/run does: no new motion, the
    one under way stopped by the driver; the summary keeps the palette asked for."""
    episode = episode_node(launch, tmp_path, decision_timeout=120.0, motion_timeout=120.0)
    cell = scripted_cell(driver="hold") if wait == "motion" else None  # else: no decision ever comes
    nothing = trigger(ros_node, names.STOP_EPISODE_SERVICE, episode)
    assert not nothing.success and nothing.message == "no episode is running"
    start = call_service(ros_node, StartEpisode, "/episode/start",
                         StartEpisode.Request(scenario="random", seed=4, palette="coal_slate"),
                         processes=[episode])
    assert start.accepted
    if wait == "motion":
        spin_until(ros_node, lambda: cell.motions, 60.0, "the motion under way", [episode])
    else:
        spin_until(ros_node, lambda: any(r["event"] == "start" for r in steps_in(tmp_path)), 60.0,
                   "the episode waiting for a decision", [episode])
    busy = trigger(ros_node, names.EPISODE_STATUS_SERVICE, episode)
    assert not busy.success
    assert busy.message.startswith(f"busy: an episode is already running ({start.episode_id}")
    stopped = trigger(ros_node, names.STOP_EPISODE_SERVICE, episode)
    assert stopped.success and stopped.message.startswith(f"episode {start.episode_id} ended: canceled")
    record = tmp_path / start.episode_id
    summary = json.loads((record / "summary.json").read_text())
    assert summary["termination_reason"] == "canceled" and summary["request"]["palette"] == "coal_slate"
    events = [r["event"] for r in read_steps(record / "steps.jsonl")]
    if wait == "motion":  # stopped by the driver, and recorded
        assert cell.motion_canceled.is_set() and events == ["start", "step", "end"]
        assert len(cell.motions) == 1  # no new motion after the stop
    else:
        assert events == ["start", "end"]
    spin_until(ros_node, lambda: f"episode {start.episode_id}: random seed 4, palette coal_slate" in
               episode.output(), 10.0, "the episode's start in the node's log", [episode])
    assert trigger(ros_node, names.EPISODE_STATUS_SERVICE, episode).success  # free again


@pytest.mark.parametrize("route, wait", [("service", "decision"), ("action", "decision"),
                                         ("service", "motion")])
def test_a_node_stopped_mid_episode_closes_the_record(ros_node, launch, tmp_path, scripted_cell, route, wait):
    """SIGINT on the episode node (the cell stopped) while an episode waits: the record gets its end
    line and summary ("canceled") before the process exits. rclpy shuts the node's context down before
    the node can stop its episode: an error that raises is the stop, not an "error: ..." end."""
    episode = episode_node(launch, tmp_path, decision_timeout=120.0, motion_timeout=120.0)
    cell = scripted_cell(driver="hold") if wait == "motion" else None
    goal = dict(scenario="random", seed=5)
    if route == "service":
        assert call_service(ros_node, StartEpisode, "/episode/start", StartEpisode.Request(**goal),
                            processes=[episode]).accepted
    else:
        action = ActionHelper(ros_node, RunEpisode, "/episode/run", processes=[episode])
        assert action.send_goal(RunEpisode.Goal(**goal)).accepted
    if wait == "motion":
        spin_until(ros_node, lambda: cell.motions, 60.0, "the motion under way", [episode])
    else:
        spin_until(ros_node, lambda: any(r["event"] == "start" for r in steps_in(tmp_path)), 60.0,
                   "the episode waiting for a decision", [episode])
    episode.send_signal(signal.SIGINT)
    spin_until(ros_node, lambda: not episode.alive, 30.0, "the episode node to exit")
    [record] = [path for path in tmp_path.iterdir() if path.is_dir()]
    assert [r["event"] for r in read_steps(record / "steps.jsonl")][-1] == "end"
    assert json.loads((record / "summary.json").read_text())["termination_reason"] == "canceled"
    if route == "action":
        action.destroy()
