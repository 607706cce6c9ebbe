"""The picking loop (paper section 4), written once: look, decide, act, count, until the episode ends.

It runs against a small cell interface with two adapters: the ROS clients of the episode node
(impurity_policy.ros_cell.RosCell) and the fast simulator (impurity_learning.evaluate.SimCell, used by
the paper's evaluation and by training-time checks). Both therefore count, stop and record the same way.

    summary = run_episode(cell, EpisodeRequest("challenging", seed=3), "ep-1", recorder=recorder)
    summary["termination_reason"], summary["targets_picked"], summary["grasp_success"]

A cell (duck-typed, see `Cell`):
    reset(request) -> Targets | int  start the episode's scene; its targets (an int: all in the workspace)
    observe() -> View                a view taken after the last motion finished
    decide(view) -> Action | None    the primitive to execute (None: nothing to act on)
    execute(action) -> Outcome       run it; EpisodeAborted when the cell cannot go on
    targets_remaining(outcome, before) -> Targets | int   targets after the outcome (before: those left
                                     in the workspace before it)
    set_should_stop(should_stop)     optional, for cells whose verbs wait (RosCell): every wait checks
                                     should_stop() and raises EpisodeCanceled when it says so

Targets outside the workspace (from the start or pushed out) are counted apart: they cannot be picked,
and an episode that picked every other one ends "all_reachable_targets_picked", not completed.

The loop stops when every target in the workspace is picked, at the action limit, after repeated
failures, when attention (or the decision) finds nothing to act on, on a cancel (`should_stop`: asked
before each look and before each motion, and in the cell's own waits), or when the cell raises
EpisodeAborted (its message is the reason). The records (episode.EpisodeRecorder) are closed whatever
happens.
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


class EpisodeCanceled(Exception):
    """Raised by a cell's wait when should_stop() says so; the episode ends "canceled". The message says
    what was being waited for."""


@dataclass(frozen=True)
class Targets:
    """Where the scene's targets are: in the workspace (still to pick) and outside it (not reachable)."""

    in_workspace: int
    outside: int = 0


def as_targets(value: Targets | int) -> Targets:
    """A cell's count: Targets, or an int for a cell that only knows targets in the workspace."""
    return value if isinstance(value, Targets) else Targets(int(value), 0)


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
    def reset(self, request: EpisodeRequest) -> Targets | int: ...

    def observe(self) -> View: ...

    def decide(self, view: View) -> Action | None: ...

    def execute(self, action: Action) -> Outcome: ...

    def targets_remaining(self, outcome: Outcome, before: int) -> Targets | int: ...


@dataclass(frozen=True)
class EpisodeLimits:
    actions_per_target: int = DEFAULT_ACTIONS_PER_TARGET  # when a request's max_actions is 0
    max_consecutive_failures: int = DEFAULT_MAX_CONSECUTIVE_FAILURES


def step_record(index: int, action: Action, outcome: Outcome, remaining: int, outside: int = 0,
                message: str | None = None) -> StepRecord:
    return StepRecord(
        step=index, attention_mode=MODE_NAMES.get(action.mode, str(action.mode)), kind=action.kind,
        position=tuple(action.position), yaw=float(action.yaw), q_value=float(action.q_value),
        rotation_index=int(action.rotation_index), pixel=tuple(int(v) for v in action.pixel),
        decision_stamp_ns=int(action.decision_stamp_ns), motion_finished_ns=int(outcome.finished_ns),
        success=bool(outcome.success), target_grasped=bool(outcome.target_grasped),
        object_grasped=bool(outcome.success and action.kind == "grasp"), targets_remaining=int(remaining),
        message=outcome.message if message is None else message, targets_outside=int(outside))


def run_episode(cell: Cell, request: EpisodeRequest, episode_id: str, limits: EpisodeLimits = EpisodeLimits(),
                recorder: EpisodeRecorder | None = None, on_step: Callable[[StepRecord], None] | None = None,
                should_stop: Callable[[], bool] | None = None, clock_ns: Callable[[], int] | None = None,
                on_error: Callable[[Exception], None] | None = None) -> dict:
    """One episode on `cell`. Returns the paper's metrics (episode.EpisodeTracker.metrics) with
    termination_reason and completed (every target picked); with a recorder, also what it wrote
    (record_path). `on_step` sees each step after it is recorded; `should_stop` (a cancel) is asked before
    each look and before each motion, and handed to the cell (set_should_stop) for its waits: no motion
    starts after it said so; `clock_ns` stamps the start record (the time after which views show the
    scene); `on_error` sees an unexpected exception before the episode is closed as "error: ...".
    """
    tracker = EpisodeTracker(episode_id, request, request.num_targets, 0, limits.max_consecutive_failures)
    stop = should_stop or (lambda: False)
    bind_stop = getattr(cell, "set_should_stop", None) if should_stop is not None else None
    reason = None
    try:
        if bind_stop is not None:
            bind_stop(should_stop)
        scene = as_targets(cell.reset(request))
        tracker.set_scene(scene.in_workspace, scene.outside)
        tracker.max_actions = action_limit(request, scene.in_workspace, limits.actions_per_target)
        if recorder is not None:
            recorder.write_start(request, tracker.targets_total, tracker.max_actions,
                                 clock_ns() if clock_ns else 0, targets_outside=scene.outside)
        reason = tracker.termination()
        first_view = True
        while reason is None:
            if stop():
                reason = TERMINATION_CANCELED
                break
            view = cell.observe()
            if first_view and recorder is not None and view.color is not None:
                recorder.write_first_view(view.color)
            first_view = False
            action = None if view.mode == AttentionMode.NONE else cell.decide(view)
            if action is None:
                reason = TERMINATION_NOTHING_LEFT
                break
            if stop():  # a cancel that came while the decision was awaited: no new motion
                reason = TERMINATION_CANCELED
                break
            outcome = cell.execute(action)
            message = None
            try:
                after = as_targets(cell.targets_remaining(outcome, tracker.targets_remaining))
            except EpisodeCanceled:  # the motion happened: record it with the counts from before it
                after = Targets(tracker.targets_remaining, tracker.targets_outside)
                message = f"{outcome.message} (targets not recounted: canceled)"
                reason = TERMINATION_CANCELED
            step = step_record(tracker.actions + 1, action, outcome, after.in_workspace, after.outside,
                               message)
            tracker.record(step)
            if recorder is not None:
                recorder.write_step(step)
            if on_step is not None:
                on_step(step)
            reason = reason or tracker.termination()
    except EpisodeCanceled:
        reason = TERMINATION_CANCELED
    except EpisodeAborted as error:
        reason = str(error)
    except Exception as error:  # noqa: BLE001 - the record must close whatever went wrong
        if on_error is not None:
            on_error(error)
        reason = f"error: {error!r}"
    finally:
        if bind_stop is not None:
            bind_stop(None)
    metrics = tracker.metrics()
    summary = {**metrics, "termination_reason": reason,
               "completed": tracker.targets_total > 0 and metrics["targets_picked"] == tracker.targets_total}
    if recorder is not None:
        summary = recorder.write_summary(summary, reason)
        recorder.write_picture()
    return summary
