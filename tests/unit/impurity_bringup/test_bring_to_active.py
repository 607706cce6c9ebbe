"""bring_to_active (impurity_bringup.lifecycle): configure, then activate, a lifecycle node through its
services. An answer DDS drops (the service's request reader matched before the client's response reader)
is asked for again; a transition is never asked twice. Specified against stand-in service clients."""

from types import SimpleNamespace

import pytest

from impurity_bringup import lifecycle


class Future:
    def __init__(self, result=None):
        self._result = result

    def done(self) -> bool:
        return self._result is not None

    def result(self):
        return self._result


class Node:
    """Hands out a get_state client whose first `lost` answers never arrive, and a change_state client that
    moves the state along; records every call."""

    def __init__(self, lost: int):
        self.state, self.lost, self.calls = "unconfigured", lost, []

    def create_client(self, kind, name):
        return SimpleNamespace(service_is_ready=lambda: True, call_async=self._get_state
                               if name.endswith("get_state") else self._change_state)

    def destroy_client(self, client):
        pass

    def _get_state(self, request):
        self.calls.append("get_state")
        if self.lost:
            self.lost -= 1
            return Future()
        return Future(SimpleNamespace(current_state=SimpleNamespace(label=self.state)))

    def _change_state(self, request):
        self.calls.append("change_state")
        self.state = {"unconfigured": "inactive", "inactive": "active"}[self.state]
        return Future(SimpleNamespace(success=True))


def test_a_lost_get_state_answer_is_asked_for_again_and_the_node_comes_up(monkeypatch):
    monkeypatch.setattr(lifecycle, "GET_STATE_RESEND", 0.05)
    node = Node(lost=2)
    lifecycle.bring_to_active(node, "/ur5_driver", timeout=5.0, spin_once=lambda timeout_sec: None)
    assert node.state == "active"
    assert node.calls == ["get_state"] * 3 + ["change_state", "get_state", "change_state"]


def test_no_answer_within_the_timeout_names_the_service(monkeypatch):
    monkeypatch.setattr(lifecycle, "GET_STATE_RESEND", 0.05)
    with pytest.raises(lifecycle.LifecycleFailed, match="get_state was not answered within 0 s"):
        lifecycle.bring_to_active(Node(lost=10**6), "/ur5_driver", timeout=0.3,
                                  spin_once=lambda timeout_sec: None)
