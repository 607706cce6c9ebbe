"""Bring a lifecycle node of the cell (the UR5 driver) to active through its lifecycle services, as
`ros2 lifecycle set <node> configure` then `... activate` would: what the pip launcher (launch_cell) does
once the driver's process runs. (The ROS launch file does the same with launch_ros's LifecycleNode and
lifecycle events.)

A transition that fails is reported with the reason the node gives on /diagnostics (its status message):
"/ur5_driver did not become active: unconfigured: configure failed: cannot connect to the UR controller
at 192.168.1.10: ...".
"""

from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState

from impurity_common import names

ACTIVATION = (("configure", Transition.TRANSITION_CONFIGURE, "inactive"),
              ("activate", Transition.TRANSITION_ACTIVATE, "active"))
REASON_WAIT = 3.0  # s to wait for the node's /diagnostics after a failed transition (published at 1 Hz)


class LifecycleFailed(RuntimeError):
    """A transition failed or was not answered; str() names the node, the transition and the reason."""


def _spin_until(spin_once, done, timeout: float, should_stop) -> bool:
    deadline = time.monotonic() + timeout
    while not done():
        if should_stop() or time.monotonic() > deadline:
            return False
        spin_once(timeout_sec=0.05)
    return True


GET_STATE_RESEND = 2.0  # s: get_state asked again after this without an answer


def _current_state(get_state, spin_once, timeout: float, should_stop) -> str | None:
    """The node's lifecycle state label, or None without an answer within `timeout` s. The question is asked
    again every GET_STATE_RESEND s: a service whose request reader has matched may not yet have matched the
    client's response reader, and DDS then drops the answer (asking is harmless; a transition is not asked
    twice)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        asked = get_state.call_async(GetState.Request())
        wait = min(GET_STATE_RESEND, deadline - time.monotonic())
        if _spin_until(spin_once, asked.done, wait, should_stop):
            return asked.result().current_state.label
        if should_stop():
            return None
    return None


def _reason(node, target: str, spin_once, should_stop) -> str | None:
    """The node's own status message on /diagnostics (None when it publishes none within REASON_WAIT s)."""
    name = target.rsplit("/", 1)[-1]
    heard: list[str] = []

    def on_diagnostics(msg: DiagnosticArray) -> None:
        heard.extend(status.message for status in msg.status if status.name == name)

    subscription = node.create_subscription(DiagnosticArray, names.DIAGNOSTICS_TOPIC, on_diagnostics, 10)
    try:
        _spin_until(spin_once, lambda: bool(heard), REASON_WAIT, should_stop)
    finally:
        node.destroy_subscription(subscription)
    return heard[-1] if heard else None


def bring_to_active(node, target: str, timeout: float = 60.0, should_stop=lambda: False,
                    spin_once=None) -> None:
    """Configure, then activate, the lifecycle node `target` (e.g. "/ur5_driver"), using `node` as the
    client and `spin_once(timeout_sec=...)` to wait (default: rclpy.spin_once(node)); a transition is
    skipped when the node is already past it. LifecycleFailed names the failed transition and the node's
    reason; `timeout` bounds the wait for the services and each answer."""
    if spin_once is None:
        import rclpy

        def spin_once(timeout_sec):
            rclpy.spin_once(node, timeout_sec=timeout_sec)
    get_state = node.create_client(GetState, f"{target}/get_state")
    change_state = node.create_client(ChangeState, f"{target}/change_state")
    try:
        def ready() -> bool:
            return change_state.service_is_ready() and get_state.service_is_ready()

        if not _spin_until(spin_once, ready, timeout, should_stop):
            raise LifecycleFailed(f"{target}: its lifecycle services did not appear within {timeout:.0f} s")
        for label, transition, reached in ACTIVATION:
            state = _current_state(get_state, spin_once, timeout, should_stop)
            if state is None:
                raise LifecycleFailed(f"{target}: get_state was not answered within {timeout:.0f} s")
            if state == "active" or (state == reached and label == "configure"):
                continue
            answer = change_state.call_async(ChangeState.Request(transition=Transition(id=transition)))
            if not _spin_until(spin_once, answer.done, timeout, should_stop):
                raise LifecycleFailed(f"{target}: {label} was not answered within {timeout:.0f} s")
            if not answer.result().success:
                reason = _reason(node, target, spin_once, should_stop)
                raise LifecycleFailed(f"{target} did not become active: "
                                      + (reason or f"{label} failed (its log says why)"))
    finally:
        node.destroy_client(get_state)
        node.destroy_client(change_state)
