"""ROS clients that cannot lose a response, whatever the rclpy version.

rclpy's ActionClient (up to at least 7.1.6, the Jazzy wheel we pin) sends a goal, cancel or result
request first and registers its sequence number afterwards. When the executor thread takes the server's
response in between, the response is dropped with "Ignoring unexpected goal response. There may be more
than one action server ..." and the future never completes (ros2/rclpy#1123; fixed upstream later by a
lock in the client). On a real arm a blind re-send would move the robot twice, so the project's action
clients close the gap themselves: `RaceFreeActionClient` holds a lock from sending to registering, and
the executor's `execute` waits for that lock before it looks the response up. With an rclpy that has
the upstream fix, the extra lock costs nothing.

A second way to lose a goal's answer is below rclpy: rmw_fastrtps sends a service response only once the
client's response reader is matched, waits briefly for that, and otherwise drops it ("failed to send
response (timeout): client will not receive response"). A client created just before its first goal can
meet it on a loaded machine: the server accepts and runs the goal, its feedback and status arrive, and
the goal response never does. `RaceFreeActionClient` remembers which goals the server has been heard
about (feedback or status), and `adopt_accepted_goal` gives a goal handle for such a goal, registered as
rclpy registers its own, so that its result can still be asked for (the result request goes out later,
when discovery is done) - no goal is ever sent twice.

Service clients need no wrapper in Jazzy: `rclpy.client.Client.call_async` already registers under
its own lock (checked in tests/unit/impurity_common/test_clients.py, which also reproduces the action
race with a delayed registration).

    client = RaceFreeActionClient(node, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION)
    future = client.send_goal_async(goal)   # as rclpy's
    handle = client.send_goal_following(goal, wait)   # a goal whose response may be lost: see its docstring
"""

from __future__ import annotations

import threading
import uuid
import weakref
from collections.abc import Callable

from rclpy.action import ActionClient
from rclpy.action.client import ClientGoalHandle
from unique_identifier_msgs.msg import UUID

# s a client that has heard of its goal (heard_of) still waits for the goal response before it follows the
# goal without it (adopt_accepted_goal): RaceFreeActionClient.send_goal_following
LOST_RESPONSE_GRACE = 2.0

# The request methods whose send-then-register window the lock closes (names in rclpy 7.1.x).
GUARDED_METHODS = ("send_goal_async", "_cancel_goal_async", "_get_result_async")


class RaceFreeActionClient(ActionClient):
    """rclpy.action.ActionClient whose responses cannot arrive before their request is registered."""

    def __init__(self, *args, **kwargs):
        self._registration_lock = threading.RLock()
        self._heard = set()  # goal ids (bytes) the server published feedback or status about
        super().__init__(*args, **kwargs)

    def send_goal_async(self, *args, **kwargs):
        with self._registration_lock:
            return super().send_goal_async(*args, **kwargs)

    def _cancel_goal_async(self, *args, **kwargs):
        with self._registration_lock:
            return super()._cancel_goal_async(*args, **kwargs)

    def _get_result_async(self, *args, **kwargs):
        with self._registration_lock:
            return super()._get_result_async(*args, **kwargs)

    async def execute(self, taken_data):
        """Responses taken from the wait set are matched only once no request is half-registered: a
        response can only exist after its request was sent, and the sender held the lock until it
        had registered it. Feedback and status messages record which goals the server knows."""
        with self._registration_lock:
            pass
        if "goal" in taken_data and self._late_response_of_adopted_goal(*taken_data["goal"]):
            taken_data = {key: value for key, value in taken_data.items() if key != "goal"}
        if "feedback" in taken_data:
            self._heard.add(bytes(taken_data["feedback"].goal_id.uuid))
        if "status" in taken_data:
            self._heard.update(bytes(status.goal_info.goal_id.uuid)
                               for status in taken_data["status"].status_list)
        return await super().execute(taken_data)

    def _late_response_of_adopted_goal(self, sequence_number, response) -> bool:
        """Whether this goal response belongs to a goal already followed without it (adopt_accepted_goal): its
        request's future gets the adopted handle, and rclpy, which would take the response for a second goal
        of the same id and raise, never sees it."""
        goal_id = self._goal_sequence_number_to_goal_id.get(sequence_number)
        adopted = self._goal_handles.get(bytes(goal_id.uuid)) if goal_id is not None else None
        handle = adopted() if adopted is not None else None
        if handle is None or not response.accepted:
            return False
        self._pending_goal_requests[sequence_number].set_result(handle)
        return True

    def heard_of(self, goal_uuid) -> bool:
        """Whether the server has published feedback or status about this goal (a unique_identifier_msgs
        UUID): it accepted the goal, whether or not its goal response arrived."""
        return bytes(goal_uuid.uuid) in self._heard

    def adopt_accepted_goal(self, goal_uuid) -> ClientGoalHandle:
        """A ClientGoalHandle for a goal the server accepted (heard_of) whose goal response was lost,
        registered like the handles rclpy makes from a response (status updates reach it;
        get_result_async works).
        Raises ValueError for a goal the server has not been heard about: without that evidence it may
        not run, and sending it again could run it twice."""
        key = bytes(goal_uuid.uuid)
        if key not in self._heard:
            raise ValueError("the server has published nothing about this goal: it may not have accepted it")
        response = self._action_type.Impl.SendGoalService.Response()
        response.accepted = True
        handle = ClientGoalHandle(self, goal_uuid, response)
        with self._registration_lock:
            self._goal_handles.setdefault(key, weakref.ref(handle))
        return handle

    def send_goal_following(self, goal, wait: Callable[[Callable[[], bool], float], bool],
                            feedback_callback=None, answer_timeout: float = 30.0,
                            on_adopt: Callable[[], None] | None = None) -> ClientGoalHandle | None:
        """Send `goal` under a fresh goal id and wait for the server's answer: the goal handle (check
        .accepted), or None when neither the goal response nor any feedback or status about the goal came
        within answer_timeout s.

        wait(predicate, seconds) -> bool is the caller's spin loop: it spins the client's node until
        predicate() holds (True) or `seconds` pass (False), and may stop early for its own reasons
        (Ctrl-C, a dead process). When the server reports on the goal (heard_of) but its goal response
        has not come (lost below rclpy, see the module docstring), the response gets LOST_RESPONSE_GRACE
        s more; then the goal is followed without it through adopt_accepted_goal, and on_adopt() is
        called so the caller can say so. The goal is never sent twice."""
        goal_id = UUID(uuid=list(uuid.uuid4().bytes))
        future = self.send_goal_async(goal, goal_uuid=goal_id, feedback_callback=feedback_callback)
        wait(lambda: future.done() or self.heard_of(goal_id), answer_timeout)
        if not future.done() and self.heard_of(goal_id):
            wait(future.done, LOST_RESPONSE_GRACE)
        if future.done():
            return future.result()
        if not self.heard_of(goal_id):
            return None
        if on_adopt is not None:
            on_adopt()
        return self.adopt_accepted_goal(goal_id)
