"""A stall look through the separate executables of the cell: the episode node asks the attention node for one
(/attention/look_closer) after stall_look_views views in a row with a heap but no impurity, decides on the
look, and switches it off again (impurity_policy.core.picking's module docstring)."""

from test_episode_graph import launch_cell, steps_of

from impurity_attention.core.verifier import default_verifier
from impurity_interfaces.action import RunEpisode
from ros_harness import ActionHelper, spin_until


def test_the_episode_node_decides_on_a_stall_look_and_switches_it_off(ros_node, launch, tmp_path):
    # a stall look on the first view with a heap but no impurity (5 in a row by default). The known product
    # is off: the scene's likeliest region reads under the last look (0.27 against 0.391), so the loop would
    # remember its colour as product and the look would pass it over (the known product's own graph tests
    # cover that); here the look alone decides
    processes = launch_cell(launch, tmp_path, stall_look_views=1, known_product=False)
    procs = list(processes.values())
    episode = ActionHelper(ros_node, RunEpisode, "/episode/run", timeout=60.0, processes=procs)
    # the first view of invisible scene 5 on the default palette: its likeliest region reads 0.27 against
    # the verifier's 0.74, with a heap left (tests/graph/test_attention_graph.py); at the stall look's
    # threshold (0.134) it is a target
    handle, wrapped = episode.run(RunEpisode.Goal(scenario="invisible", seed=5, palette="blocks",
                                                  max_actions=1), timeout=400.0)
    assert handle.accepted
    steps = steps_of(wrapped.result.record_path)
    # decided on the look: a target (the network may grasp it or push at it)
    assert len(steps) == 1 and steps[0]["attention_mode"] == "TARGET", steps
    attention = processes["attention_node"]
    spin_until(ros_node, lambda: "stall look off" in attention.output(), 30.0, "the stall look switched off",
               procs)
    threshold = default_verifier().stall_look
    assert f"stall look on: verifier threshold {threshold:.2f}" in attention.output()
    episode.destroy()
