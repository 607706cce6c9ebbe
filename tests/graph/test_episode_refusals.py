"""Episode node on its own: bad requests and a second start are refused with a reason, and an episode
whose cell does not answer ends with a clear reason and an intact record."""

import json

from impurity_interfaces.action import RunEpisode
from impurity_interfaces.srv import StartEpisode
from ros_harness import ActionHelper, call_service, ros_args, spin_until


def test_refusals_and_a_missing_cell(ros_node, launch, tmp_path):
    episode = launch("impurity_policy", "episode_node",
                     ros_args({"record_dir": str(tmp_path), "service_timeout": 6.0}))

    bad = call_service(ros_node, StartEpisode, "/episode/start",
                       StartEpisode.Request(scenario="moon_rocks"), processes=[episode], resend_after=5.0)
    assert not bad.accepted and "unknown scenario 'moon_rocks'" in bad.reason
    negative = call_service(ros_node, StartEpisode, "/episode/start",
                            StartEpisode.Request(num_objects=-4), processes=[episode], resend_after=5.0)
    assert not negative.accepted and "num_objects must be >= 0" in negative.reason

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
    retry = call_service(ros_node, StartEpisode, "/episode/start",
                         StartEpisode.Request(scenario="random", seed=3), processes=[episode])
    assert retry.accepted
    action.destroy()
