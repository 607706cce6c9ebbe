"""The picking loop (paper section 4), written once: look, decide, act, count, until the episode ends.

It runs against a small cell interface with two adapters: the ROS clients of the episode node
(impurity_policy.ros_cell.RosCell) and the fast simulator (impurity_learning.sim_cell.SimCell, used by
the paper's evaluation and by training-time checks). Both therefore count, stop and record the same way.

    summary = run_episode(cell, EpisodeRequest("challenging", seed=3), "ep-1", recorder=recorder)
    summary["termination_reason"], summary["targets_picked"], summary["grasp_success"]

A cell (duck-typed, see `Cell`):
    reset(request) -> int            start the episode's scene; how many targets it holds
    observe() -> View                a view taken after the last motion finished
    decide(view) -> Action | None    the primitive to execute (None: nothing to act on)
    execute(action) -> Outcome       run it; EpisodeAborted when the cell cannot go on
    targets_remaining(outcome, before) -> int   targets left after the outcome

The loop stops when every target is picked, at the action limit, after repeated failures, when
attention (or the decision) finds nothing to act on, on a cancel (`should_stop`), or when the cell
raises EpisodeAborted (its message is the reason). The records (episode.EpisodeRecorder) are closed
whatever happens.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from impurity_common.enums import AttentionMode

from .episode import (
    DEFAULT_ACTIONS_PER_TARGET,
    DEFAULT_MAX_CONSECUTIVE_FAILURES,
    TERMINATION_CANCELED,
    TERMINATION_NOTHING_LEFT,
    EpisodeRecorder,
    EpisodeRequest,
    EpisodeTracker,
    StepRecord,
    action_limit,
)

MODE_NAMES = {int(mode): mode.name for mode in AttentionMode}  # 1 -> "TARGET", as the records spell it


class EpisodeAborted(Exception):
    """The episode cannot go on; the message is its termination reason (e.g. "node_lost: ...")."""


@dataclass
class View:
    """One look at the cell. mode: the attention mode the decision will answer (AttentionResult.MODE_*);
    color: the colour heightmap (H, W, 3) uint8 for the episode's picture, or None; source: the
    adapter's own data (attention result, sensed state)."""

    mode: int
    color: np.ndarray | None = None
    source: object = None


@dataclass
class Action:
    """One primitive in base_link: kind "push" | "grasp", position (m), yaw (rad), its Q value (NaN for
    a heuristic), rotation index and heightmap pixel (row, col), the attention mode it answers, the
    stamp (ns) of the camera frame it was decided on (0 in the fast sim); source: the adapter's own."""

    kind: str
    position: tuple
    yaw: float
    q_value: float
    rotation_index: int
    pixel: tuple
    mode: int
    decision_stamp_ns: int = 0
    source: object = None


@dataclass
class Outcome:
    """What the cell reports after a motion: success (a grasp: something lifted; a push: the motion
    completed), whether a target was lifted, a message, and when the motion finished (ns, 0 in the
    fast sim)."""

    success: bool
    target_grasped: bool
    message: str = ""
    finished_ns: int = 0


class Cell(Protocol):
    def reset(self, request: EpisodeRequest) -> int: ...

    def observe(self) -> View: ...

    def decide(self, view: View) -> Action | None: ...

    def execute(self, action: Action) -> Outcome: ...

    def targets_remaining(self, outcome: Outcome, before: int) -> int: ...


@dataclass(frozen=True)
class EpisodeLimits:
    actions_per_target: int = DEFAULT_ACTIONS_PER_TARGET  # when a request's max_actions is 0
    max_consecutive_failures: int = DEFAULT_MAX_CONSECUTIVE_FAILURES


def step_record(index: int, action: Action, outcome: Outcome, remaining: int) -> StepRecord:
    return StepRecord(
        step=index, attention_mode=MODE_NAMES.get(action.mode, str(action.mode)), kind=action.kind,
        position=tuple(action.position), yaw=float(action.yaw), q_value=float(action.q_value),
        rotation_index=int(action.rotation_index), pixel=tuple(int(v) for v in action.pixel),
        decision_stamp_ns=int(action.decision_stamp_ns), motion_finished_ns=int(outcome.finished_ns),
        success=bool(outcome.success), target_grasped=bool(outcome.target_grasped),
        object_grasped=bool(outcome.success and action.kind == "grasp"), targets_remaining=int(remaining),
        message=outcome.message)


def run_episode(cell: Cell, request: EpisodeRequest, episode_id: str, limits: EpisodeLimits = EpisodeLimits(),
                recorder: EpisodeRecorder | None = None, on_step: Callable[[StepRecord], None] | None = None,
                should_stop: Callable[[], bool] | None = None, clock_ns: Callable[[], int] | None = None,
                on_error: Callable[[Exception], None] | None = None) -> dict:
    """One episode on `cell`. Returns the paper's metrics (episode.EpisodeTracker.metrics) with
    termination_reason and completed (every target picked); with a recorder, also what it wrote
    (record_path). `on_step` sees each step after it is recorded; `should_stop` is asked after each
    step (a cancel); `clock_ns` stamps the start record (the time after which views show the scene);
    `on_error` sees an unexpected exception before the episode is closed as "error: ...".
    """
    tracker = EpisodeTracker(episode_id, request, request.num_targets, 0, limits.max_consecutive_failures)
    reason = None
    try:
        total = cell.reset(request)
        tracker.targets_total = tracker.targets_remaining = total
        tracker.max_actions = action_limit(request, total, limits.actions_per_target)
        if recorder is not None:
            recorder.write_start(request, total, tracker.max_actions, clock_ns() if clock_ns else 0)
        reason = tracker.termination()
        first_view = True
        while reason is None:
            view = cell.observe()
            if first_view and recorder is not None and view.color is not None:
                recorder.write_first_view(view.color)
            first_view = False
            action = None if view.mode == AttentionMode.NONE else cell.decide(view)
            if action is None:
                reason = TERMINATION_NOTHING_LEFT
                break
            outcome = cell.execute(action)
            remaining = cell.targets_remaining(outcome, tracker.targets_remaining)
            step = step_record(tracker.actions + 1, action, outcome, remaining)
            tracker.record(step)
            if recorder is not None:
                recorder.write_step(step)
            if on_step is not None:
                on_step(step)
            reason = tracker.termination()
            if reason is None and should_stop is not None and should_stop():
                reason = TERMINATION_CANCELED
    except EpisodeAborted as error:
        reason = str(error)
    except Exception as error:  # noqa: BLE001 - the record must close whatever went wrong
        if on_error is not None:
            on_error(error)
        reason = f"error: {error!r}"
    metrics = tracker.metrics()
    summary = {**metrics, "termination_reason": reason,
               "completed": tracker.targets_total > 0 and metrics["targets_picked"] == tracker.targets_total}
    if recorder is not None:
        summary = recorder.write_summary(summary, reason)
        recorder.write_picture()
    return summary
