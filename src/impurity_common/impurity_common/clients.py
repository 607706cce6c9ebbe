"""ROS clients that cannot lose a response, whatever the rclpy version.

rclpy's ActionClient (up to at least 7.1.6, the Jazzy wheel we pin) sends a goal, cancel or result
request first and registers its sequence number afterwards. When the executor thread takes the server's
response in between, the response is dropped with "Ignoring unexpected goal response. There may be more
than one action server ..." and the future never completes (ros2/rclpy#1123; fixed upstream later by a
lock in the client). On a real arm a blind re-send would move the robot twice, so the project's action
clients close the gap themselves: `RaceFreeActionClient` holds a lock from sending to registering, and
the executor's `execute` waits for that lock before it looks the response up. With an rclpy that has
the upstream fix, the extra lock costs nothing.

Service clients need no wrapper in Jazzy: `rclpy.client.Client.call_async` already registers under
its own lock (checked in tests/unit/impurity_common/test_clients.py, which also reproduces the action
race with a delayed registration).

    client = RaceFreeActionClient(node, ExecutePrimitive, names.EXECUTE_PRIMITIVE_ACTION)
    future = client.send_goal_async(goal)   # as rclpy's
"""

from __future__ import annotations

import threading

from rclpy.action import ActionClient

# The request methods whose send-then-register window the lock closes (names in rclpy 7.1.x).
GUARDED_METHODS = ("send_goal_async", "_cancel_goal_async", "_get_result_async")


class RaceFreeActionClient(ActionClient):
    """rclpy.action.ActionClient whose responses cannot arrive before their request is registered."""

    def __init__(self, *args, **kwargs):
        self._registration_lock = threading.RLock()
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
        had registered it."""
        with self._registration_lock:
            pass
        return await super().execute(taken_data)
