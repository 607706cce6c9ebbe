"""An episode counted by perception on a camera that gives no depth on a black piece: the piece's colour
reaches the heightmap as height unknown and attention targets it, so three views of it do not end the
episode "nothing left". No ROS, no simulator: the views are attention's answers on synthetic frames whose
impurity pixels have no depth (0 in 16UC1, as the RealSense driver publishes it)."""

import numpy as np
import pytest

from impurity_attention.core import heightmap as hm
from impurity_attention.core.attention import attend
from impurity_attention.core.synthetic import random_boxes, render_boxes
from impurity_policy.core.episode import TERMINATION_ACTION_LIMIT, EpisodeRequest
from impurity_policy.core.picking import Action, EpisodeLimits, Outcome, View, run_episode
from impurity_policy.core.policy import MODE_NONE


def black_piece_view() -> View:
    """The view the attention node makes of a frame whose black impurity has no depth."""
    boxes = random_boxes(1, num_product=12, num_impurities=1, impurity_color=(25, 25, 28))
    frame = render_boxes(boxes)
    raw = np.round(frame.depth * 1000.0).astype(np.uint16)
    raw[frame.labels == boxes[-1].label] = 0
    depth = hm.depth_to_meters(raw, "16UC1")
    maps = hm.HeightmapProjector(frame.intrinsics, frame.camera_pose, depth.shape).project(frame.color, depth)
    height = maps.height_or_unknown()  # as /heightmap carries it
    output = attend(maps.color, height, unknown=np.isnan(height))
    return View(int(output.mode), maps.color, None, output.height, output.target_mask, output.score,
                output.last_look)


class BlackPieceCell:
    """A cell without counts that sees the same black piece in every view; pushes move nothing."""

    def __init__(self, view: View):
        self.view, self.observed = view, 0

    def reset(self, request):
        return None

    def observe(self):
        self.observed += 1
        return self.view

    def decide(self, view):
        return Action("push", (0.5, 0.0, 0.02), 0.0, 1.0, 0, (15, 15), view.mode)

    def execute(self, action):
        return Outcome(True, False, "push", holding=False)

    def truth(self):
        return None


@pytest.fixture(scope="module")
def view():
    return black_piece_view()


def test_a_black_piece_without_depth_keeps_the_episode_going(view):
    assert view.mode != MODE_NONE
    cell = BlackPieceCell(view)
    summary = run_episode(cell, EpisodeRequest("random", seed=1), "ep-1",
                          EpisodeLimits(none_frames_to_finish=3, max_actions_uncounted=4))
    assert summary["termination_reason"] == TERMINATION_ACTION_LIMIT, summary["termination_reason"]
    assert summary["actions"] == 4 and cell.observed >= 4
