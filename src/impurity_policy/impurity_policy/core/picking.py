"""The picking loop (paper section 4), written once: look, decide, act, count, until the episode ends.

It runs against a small cell interface with two adapters: the ROS clients of the episode node
(impurity_policy.ros_cell.RosCell) and the fast simulator (impurity_learning.evaluate.SimCell, used by
the paper's evaluation and by training-time checks). Both therefore count, stop and record the same way.

    summary = run_episode(cell, EpisodeRequest("challenging", seed=3), "ep-1", recorder=recorder)
    summary["termination_reason"], summary["targets_picked"], summary["grasp_success"]

A cell (duck-typed, see `Cell`):
    reset(request) -> Targets | int | None  start the episode's scene; its targets (an int: all in the
                                     workspace), or None: the cell cannot count targets (a real cell)
    observe() -> View                a view taken after the last motion (and after the last view) finished
    decide(view) -> Action | None    the primitive to execute (None: nothing to act on)
    execute(action) -> Outcome       run it; EpisodeAborted when the cell cannot go on
    targets_remaining(outcome, before) -> Targets | int   targets after the outcome (before: those left
                                     in the workspace before it); asked only when reset counted targets
    set_should_stop(should_stop)     optional, for cells whose verbs wait (RosCell): every wait checks
                                     should_stop() and raises EpisodeCanceled when it says so
    truth() -> Truth | None          optional: the simulator's truth, recorded beside the perception
                                     verdicts when reset returned None; never read by the loop's decisions
    know_product(view)               optional: the view shows product only; attention may take its
                                     colours as the known product (below); None: forget it
    look_closer() -> View | None     optional: a stall look (below) at the scene as the last view showed
                                     it; None: the cell cannot (the last view is decided on)

The known product (EpisodeLimits.known_product): when attention finds no target in the episode's first
view, that view shows product only, and the loop hands it to the cell's know_product once. The cell's
attention then passes over regions coloured like much of it while a heap is left; the region a last look
would take in that view (its near miss, perhaps an impurity the decision missed) is left out of it
(impurity_attention.core.product_memory). When the episode ends, however it ends, the loop calls
know_product(None); a cell also forgets it at its next reset. "First view without target" reads View.mode,
the mode the cell's decision answers: a cell whose decisions never answer anything but TARGET (the fast
sim's full-heightmap and no-occluded-region ablations) never gets a known product.

The stall look (EpisodeLimits.stall_look_views): on the stall_look_views-th view in a row whose mode is
OCCLUDED_REGION (pushes at heaps that have not shown an impurity), the loop asks the cell's
look_closer() for the view to decide on: attention looks again with the verifier's threshold lowered to
the verifier model's stall_look (checkpoints/verifier.json; attend's closer), so a target it has
been unsure of in a packed scene is grasped instead of pushed on for the rest of the episode. The count then
starts over.

Two ways to count:
- by truth (reset returned a count): targets outside the workspace (from the start or pushed out) are
  counted apart: they cannot be picked, and an episode that picked every other one ends
  "all_reachable_targets_picked", not completed. The loop stops when every target in the workspace is
  picked, at the action limit, after repeated failures, or when attention (or the decision) finds
  nothing to act on.
- by perception (reset returned None, a real cell): no count is needed up front. After each grasp
  the next fresh view judges it (core/verdict.py: the attended target gone from its cells and the gripper
  holding); the picked count is the number of grasps judged "impurity picked". The loop stops when
  attention answers NONE on `none_frames_to_finish` consecutive fresh views (the paper's end: no visible
  impurity and no heap that could hide one) -> "no_target_or_cluster_left", at the action limit (the
  request's, else `max_actions_uncounted`), or after repeated failures. The end of the search
  (EpisodeLimits.search_pushes): a heap that hides an impurity shows it after a few pushes, so once
  `search_pushes` views in a row have been pushes at heaps with no impurity in view (a stall look
  included), the next such view ends the episode "no_target_or_cluster_left" too: the bin is taken as
  clean. Low heaps, lower than two pieces (2 x EpisodeLimits.piece_height), are searched more
  briefly: after `low_heap_pushes` pushes in a row at them the next such view ends it as well. The table
  memory (TableMemory) ends it sooner: every view marks the cells it shows down to the table (lower than
  cell.OCCUPIED_HEIGHT); an impurity can only hide under material thicker than one piece (higher than
  piece_height + cell.OCCUPIED_HEIGHT) standing where the episode has never seen the table, so once a heap
  has been pushed (the second view in a row at heaps: an impurity a push moved is given one look) a view
  where such ground covers less than `impurity_area` ends the episode too. A last
  look (View.last_look) is
  acted on until one was in vain (answered by a push, or by a grasp its verdict says lifted no impurity);
  after that a last look counts as NONE. A grasp that lifts a product piece the verdict takes for an
  impurity does not stop them. With a cell that offers truth()
  (a simulated cell as the hardware), every step records the truth beside its verdict and the summary
  their agreement (episode.truth_audit).

Either way it stops on a cancel (`should_stop`: asked before each look and before each motion, and in the
cell's own waits), or when the cell raises EpisodeAborted (its message is the reason, e.g. "node_lost:
..." or "driver_lost: ..."). The records (episode.EpisodeRecorder) are closed whatever happens.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from impurity_common import cell as cell_geometry
from impurity_common.enums import AttentionMode
from impurity_common.parameters import check_fields, param

from .episode import (
    COUNTED_BY_NOTHING,
    COUNTED_BY_PERCEPTION,
    COUNTED_BY_TRUTH,
    DEFAULT_ACTIONS_PER_TARGET,
    DEFAULT_IMPURITY_AREA,
    DEFAULT_LOW_HEAP_PUSHES,
    DEFAULT_MAX_ACTIONS_UNCOUNTED,
    DEFAULT_MAX_CONSECUTIVE_FAILURES,
    DEFAULT_NONE_FRAMES_TO_FINISH,
    DEFAULT_PIECE_HEIGHT,
    DEFAULT_SEARCH_PUSHES,
    TERMINATION_ACTION_LIMIT,
    TERMINATION_CANCELED,
    TERMINATION_NOTHING_LEFT,
    EpisodeRecorder,
    EpisodeRequest,
    EpisodeTracker,
    StepRecord,
    action_limit,
    truth_audit,
)
from .verdict import (
    GraspVerdict,
    GripperReport,
    ProductReference,
    VerdictParams,
    judge_grasp,
    product_reference,
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


@dataclass(frozen=True)
class Truth:
    """The simulator's truth at one moment (GetGroundTruth): targets in and outside the workspace, and
    targets removed to the bin so far."""

    targets_remaining: int
    targets_outside: int
    targets_removed: int


@dataclass
class View:
    """One look at the cell. mode: the attention mode the decision will answer (AttentionResult.MODE_*);
    color: the colour heightmap (H, W, 3) uint8 for the episode's picture, or None; height: the height
    map (H, W) float m above the table, or None; target_mask: (H, W) bool, the attended target's cells
    (TARGET only, else None); target_score: its saliency contrast (inf when not given), recorded with a
    judged grasp; color, height and target_mask let the next view judge a grasp (core/verdict.py);
    source: the adapter's own data (attention result, sensed state); last_look: a TARGET attention gave as
    a last look (AttentionResult.last_look: no heap left, no region judged an impurity); heap_height:
    OCCLUDED_REGION only, the attended heap's height (m, attention's cluster height: AttentionResult.score),
    0 otherwise."""

    mode: int
    color: np.ndarray | None = None
    source: object = None
    height: np.ndarray | None = None
    target_mask: np.ndarray | None = None
    target_score: float = float("inf")  # TARGET: attention's saliency contrast (AttentionResult.score)
    last_look: bool = False
    heap_height: float = 0.0  # OCCLUDED_REGION: the attended heap's height (m)


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
    completed), whether a target was lifted (simulator truth; ignored when counting by perception), a
    message, when the motion finished (ns, 0 in the fast sim), and what a real arm knows: the whole plan
    ran, the opening between the fingers after the lift (m, -1 not measured), whether the gripper holds
    something (None: not reported)."""

    success: bool
    target_grasped: bool
    message: str = ""
    finished_ns: int = 0
    motion_completed: bool = True
    gripper_opening: float = -1.0
    holding: bool | None = None


class Cell(Protocol):
    def reset(self, request: EpisodeRequest) -> Targets | int: ...

    def observe(self) -> View: ...

    def decide(self, view: View) -> Action | None: ...

    def execute(self, action: Action) -> Outcome: ...

    def targets_remaining(self, outcome: Outcome, before: int) -> Targets | int: ...


@dataclass(frozen=True)
class EpisodeLimits:
    """When an episode ends and how it is judged (module docstring); the episode node's parameters of the
    same names (the verdict's as verdict.<name>)."""

    actions_per_target: int = param(DEFAULT_ACTIONS_PER_TARGET, "Action limit per target in the workspace "
                                    "when a request gives max_actions 0", low=1, high=1000)
    max_consecutive_failures: int = param(DEFAULT_MAX_CONSECUTIVE_FAILURES,
                                          "Failed grasps (nothing lifted) or pushes whose motion failed, "
                                          "in a row, that end the episode; a motion the driver refuses "
                                          "ends it at once", low=1, high=1000)
    none_frames_to_finish: int = param(DEFAULT_NONE_FRAMES_TO_FINISH, "Counting by perception: consecutive "
                                       "fresh frames on which attention answers NONE that end the episode",
                                       low=1, high=100)
    max_actions_uncounted: int = param(DEFAULT_MAX_ACTIONS_UNCOUNTED, "Counting by perception: action limit "
                                       "when a request gives max_actions 0", low=1, high=10000)
    verdict: VerdictParams = VerdictParams()
    known_product: bool = param(True, "When attention finds no target in an episode's first view, hand that "
                                "view to the cell as the known product (module docstring): while a heap is "
                                "left, regions coloured like much of it are not targets")
    stall_look_views: int = param(5, "After this many views in a row on which attention found a heap but no "
                                  "impurity, ask the cell for a stall look (module docstring) and decide on "
                                  "it", low=1, high=1000)
    search_pushes: int = param(DEFAULT_SEARCH_PUSHES, "Counting by perception: pushes in a row at heaps "
                               "that showed no impurity after which the bin is taken as clean (the end of "
                               "the search, module docstring); more leaves fewer hidden impurities behind "
                               "and costs more actions", low=1, high=1000)
    low_heap_pushes: int = param(DEFAULT_LOW_HEAP_PUSHES, "Counting by perception: the same for pushes in "
                                 "a row at low heaps, lower than two pieces (2 x piece_height)",
                                 low=1, high=1000)
    piece_height: float = param(DEFAULT_PIECE_HEIGHT, "Height of one piece of the product (m): a heap lower "
                                "than twice this is a low heap (low_heap_pushes), and only material higher "
                                "than this plus cell.OCCUPIED_HEIGHT can cover an impurity (the table "
                                "memory); set it to your product's", low=0.001, high=0.5)
    impurity_area: float = param(DEFAULT_IMPURITY_AREA, "Counting by perception: the footprint of the "
                                 "smallest impurity (m^2); once the ground never seen down to the table "
                                 "under material thicker than one piece is smaller than this, the search "
                                 "ends (the table memory)", low=0.0, high=1.0)

    def __post_init__(self):
        check_fields(self)


def low_heap_height(piece_height: float) -> float:
    """The height (m) below which a heap is a low heap: two pieces of `piece_height` m."""
    return 2.0 * piece_height


def hiding_height(piece_height: float) -> float:
    """The height (m) above which material can cover an impurity: one piece of `piece_height` m and the
    depth margin that tells an occupied cell from the table (cell.OCCUPIED_HEIGHT)."""
    return piece_height + cell_geometry.OCCUPIED_HEIGHT


class TableMemory:
    """Where an episode has seen the table (module docstring, the end of the search). look() marks the
    cells of each height map (H, W) float m, NaN unknown, lower than cell.OCCUPIED_HEIGHT; unexplored_area()
    is the ground (m^2) of a height map's cells higher than a hiding height that were never seen so, cells
    of unknown height included. A height map covers the workspace (cell.WORKSPACE_X x WORKSPACE_Y), so a
    cell's area follows from its shape; one of another shape than the first starts the memory over."""

    def __init__(self):
        self.seen: np.ndarray | None = None

    def look(self, height: np.ndarray | None) -> None:
        if height is None:
            return
        table = np.isfinite(height) & (height < cell_geometry.OCCUPIED_HEIGHT)
        if self.seen is None or self.seen.shape != table.shape:
            self.seen = table
        else:
            self.seen |= table

    def unexplored_area(self, height: np.ndarray | None, hiding: float) -> float:
        """m^2; inf without a height map."""
        if height is None or self.seen is None or self.seen.shape != height.shape:
            return float("inf")
        covering = ~(np.isfinite(height) & (height <= hiding))
        span = ((cell_geometry.WORKSPACE_X[1] - cell_geometry.WORKSPACE_X[0])
                * (cell_geometry.WORKSPACE_Y[1] - cell_geometry.WORKSPACE_Y[0]))
        return float(np.count_nonzero(covering & ~self.seen)) * span / height.size


@dataclass
class SearchRun:
    """The end of the search's counts (module docstring), as the loop keeps them over the views it decides
    on: pushes in a row at heaps that showed no impurity, and the last of them in a row at low heaps."""

    pushes: int = 0
    low: int = 0
    explored: bool = False  # the last view: a second OCCLUDED_REGION view in a row, too little unexplored

    def add(self, occluded: bool, heap_height: float, low_height: float, unexplored: float = float("inf"),
            impurity_area: float = 0.0) -> None:
        """Count one view decided on: an OCCLUDED_REGION view at a heap `heap_height` m high (low below
        `low_height` m) with `unexplored` m^2 of ground that could still cover an impurity
        (TableMemory.unexplored_area; explored below `impurity_area` from the second such view in a row
        on), or any other view, which starts both counts over."""
        self.pushes = self.pushes + 1 if occluded else 0
        self.low = self.low + 1 if occluded and heap_height < low_height else 0
        self.explored = occluded and self.pushes > 1 and unexplored < impurity_area

    def over(self, search_pushes: int, low_heap_pushes: int | None) -> bool:
        """Whether the search ends here: the last view explored, more than `search_pushes` in a row, or more
        than `low_heap_pushes` (None: no such limit) at low heaps."""
        return self.explored or self.pushes > search_pushes or (
            low_heap_pushes is not None and self.low > low_heap_pushes)


def step_record(index: int, action: Action, outcome: Outcome, remaining: int, outside: int = 0,
                message: str | None = None, verdict: GraspVerdict | None = None,
                truth_target_grasped: bool | None = None, target_score: float = -1.0) -> StepRecord:
    """The record of one executed step; with a verdict (counting by perception), target_grasped is the
    verdict's, not the outcome's."""
    target_grasped = verdict.impurity_picked if verdict is not None else bool(outcome.target_grasped)
    return StepRecord(
        step=index, attention_mode=MODE_NAMES.get(action.mode, str(action.mode)), kind=action.kind,
        position=tuple(action.position), yaw=float(action.yaw), q_value=float(action.q_value),
        rotation_index=int(action.rotation_index), pixel=tuple(int(v) for v in action.pixel),
        decision_stamp_ns=int(action.decision_stamp_ns), motion_finished_ns=int(outcome.finished_ns),
        success=bool(outcome.success), target_grasped=bool(target_grasped),
        object_grasped=bool(outcome.success and action.kind == "grasp"), targets_remaining=int(remaining),
        message=outcome.message if message is None else message, targets_outside=int(outside),
        motion_completed=bool(outcome.motion_completed), gripper_opening=float(outcome.gripper_opening),
        holding=bool(outcome.holding), gone_fraction=verdict.gone_fraction if verdict is not None else -1.0,
        verdict=verdict.reason if verdict is not None else "", truth_target_grasped=truth_target_grasped,
        target_score=float(target_score) if np.isfinite(target_score) else -1.0)


def run_episode(cell: Cell, request: EpisodeRequest, episode_id: str, limits: EpisodeLimits = EpisodeLimits(),
                recorder: EpisodeRecorder | None = None, on_step: Callable[[StepRecord], None] | None = None,
                should_stop: Callable[[], bool] | None = None, clock_ns: Callable[[], int] | None = None,
                on_error: Callable[[Exception], None] | None = None,
                on_started: Callable[[], None] | None = None) -> dict:
    """One episode on `cell`. Returns the paper's metrics (episode.EpisodeTracker.metrics) with
    termination_reason, counted_by ("truth" | "perception" | "nothing": it ended before the cell's reset
    returned, targets_total -1) and completed (counted by truth: every target
    picked; by perception: it ended because attention saw nothing left); counted by perception on a cell
    with truth(), also episode.truth_audit's figures; with a recorder, also what it wrote (record_path).
    `on_step` sees each step after it is recorded; `should_stop` (a cancel) is asked before each look and
    before each motion, and handed to the cell (set_should_stop) for its waits: no motion starts after it
    said so; `clock_ns` stamps the start record (the time after which views show the scene); `on_error`
    sees an unexpected exception before the episode is closed as "error: ..."; `on_started` is called once
    the cell's reset has succeeded (the scene is ready), before the first look: an episode that ends
    without it never started (its termination reason says why: a refused scene, a missing service).
    """
    tracker = EpisodeTracker(episode_id, request, request.num_targets, 0, limits.max_consecutive_failures)
    episode = _Episode(cell, request, limits, tracker, recorder, on_step, should_stop or (lambda: False))
    bind_stop = getattr(cell, "set_should_stop", None) if should_stop is not None else None
    reason, scene_ready = None, False
    try:
        if bind_stop is not None:
            bind_stop(should_stop)
        scene = cell.reset(request)
        scene_ready = True
        if on_started is not None:
            on_started()
        if scene is None:
            reason = episode.run_by_perception(clock_ns)
        else:
            reason = episode.run_by_truth(as_targets(scene), clock_ns)
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
        if episode.product_known:  # the known product is this episode's: forgotten however it ended
            try:
                cell.know_product(None)
            except Exception as error:  # noqa: BLE001 - the record must close; the next reset clears it too
                if on_error is not None:
                    on_error(error)
    summary = _summary(tracker, reason, episode.truth_targets_total, scene_ready)
    if recorder is not None:
        summary = recorder.write_summary(summary, reason)
        recorder.write_picture()
    return summary


def _summary(tracker: EpisodeTracker, reason: str, truth_targets_total: int | None,
             scene_ready: bool = True) -> dict:
    """run_episode's summary of an ended episode: the tracker's metrics, termination_reason, completed,
    counted_by and, counted by perception, the truth audit (episode.truth_audit). An episode whose scene
    was never ready (scene_ready False) counted nothing: counted_by "nothing", targets_total -1."""
    if not scene_ready:
        tracker.targets_total = -1
        return {**tracker.metrics(), "termination_reason": reason, "completed": False,
                "counted_by": COUNTED_BY_NOTHING}
    metrics = tracker.metrics()
    if tracker.counts_known:
        completed = tracker.targets_total > 0 and metrics["targets_picked"] == tracker.targets_total
    else:
        completed = reason == TERMINATION_NOTHING_LEFT
    summary = {**metrics, "termination_reason": reason, "completed": completed,
               "counted_by": COUNTED_BY_TRUTH if tracker.counts_known else COUNTED_BY_PERCEPTION}
    if not tracker.counts_known:
        summary.update(truth_audit(tracker.steps, truth_targets_total))
    return summary


class _Episode:
    """run_episode's two loops over one cell, tracker and recorder."""

    def __init__(self, cell, request, limits, tracker, recorder, on_step, stop):
        self.cell, self.request, self.limits, self.tracker = cell, request, limits, tracker
        self.recorder, self.on_step, self.stop = recorder, on_step, stop
        self.first_view = True
        self.reference: ProductReference | None = None  # the product as the first view showed it
        self.product_known = False  # the cell was handed a known product (know_product)
        self.truth_targets_total: int | None = None  # simulator truth beside perception, if offered
        self._truth_removed = 0
        self.occluded_views = 0  # OCCLUDED_REGION views in a row, for the stall look
        self.memory = TableMemory()  # where the episode has seen the table (the end of the search)

    def _look(self) -> View:
        view = self.cell.observe()
        self.memory.look(view.height)
        if self.first_view and self.recorder is not None and view.color is not None:
            self.recorder.write_first_view(view.color)
        if self.reference is None and view.color is not None and view.height is not None:
            self.reference = product_reference(view.color, view.height, view.target_mask, self.limits.verdict)
        if self.first_view and self.limits.known_product and view.mode != AttentionMode.TARGET:
            know_product = getattr(self.cell, "know_product", None)
            if know_product is not None:
                know_product(view)
                self.product_known = True
        self.first_view = False
        return view

    def _stall_look(self, view: View) -> View:
        """The view to decide on: `view`, or on the stall_look_views-th OCCLUDED_REGION view in a row the
        cell's look_closer() (module docstring); the count starts over after a look."""
        if view.mode != AttentionMode.OCCLUDED_REGION:
            self.occluded_views = 0
            return view
        self.occluded_views += 1
        look_closer = getattr(self.cell, "look_closer", None)
        if self.occluded_views < self.limits.stall_look_views or look_closer is None:
            return view
        self.occluded_views = 0
        closer = look_closer()
        if closer is not None:
            self.memory.look(closer.height)
        return view if closer is None else closer

    def _record(self, step: StepRecord) -> None:
        self.tracker.record(step)
        if self.recorder is not None:
            self.recorder.write_step(step)
        if self.on_step is not None:
            self.on_step(step)

    def run_by_truth(self, scene: Targets, clock_ns) -> str:
        """The loop counting with the cell's target counts; returns the termination reason."""
        tracker, cell = self.tracker, self.cell
        tracker.set_scene(scene.in_workspace, scene.outside)
        tracker.max_actions = action_limit(self.request, scene.in_workspace, self.limits.actions_per_target)
        if self.recorder is not None:
            self.recorder.write_start(self.request, tracker.targets_total, tracker.max_actions,
                                      clock_ns() if clock_ns else 0, targets_outside=scene.outside)
        reason = tracker.termination()
        while reason is None:
            if self.stop():
                return TERMINATION_CANCELED
            view = self._stall_look(self._look())
            action = None if view.mode == AttentionMode.NONE else cell.decide(view)
            if action is None:
                return TERMINATION_NOTHING_LEFT
            if self.stop():  # a cancel that came while the decision was awaited: no new motion
                return TERMINATION_CANCELED
            outcome = cell.execute(action)
            message = None
            try:
                after = as_targets(cell.targets_remaining(outcome, tracker.targets_remaining))
            except EpisodeCanceled:  # the motion happened: record it with the counts from before it
                after = Targets(tracker.targets_remaining, tracker.targets_outside)
                message = f"{outcome.message} (targets not recounted: canceled)"
                reason = TERMINATION_CANCELED
            self._record(step_record(tracker.actions + 1, action, outcome, after.in_workspace, after.outside,
                                     message))
            reason = reason or tracker.termination()
        return reason

    def _truth(self) -> Truth | None:
        truth = getattr(self.cell, "truth", None)
        return truth() if truth is not None else None

    def run_by_perception(self, clock_ns) -> str:
        """The loop without target counts (module docstring); returns the termination reason."""
        tracker, cell, limits = self.tracker, self.cell, self.limits
        tracker.counts_known = False
        tracker.targets_total, tracker.targets_remaining, tracker.targets_outside = -1, -1, 0
        tracker.max_actions = self.request.max_actions or limits.max_actions_uncounted
        truth = self._truth()
        if truth is not None:
            self.truth_targets_total = truth.targets_remaining + truth.targets_outside
            self._truth_removed = truth.targets_removed
        if self.recorder is not None:
            self.recorder.write_start(self.request, -1, tracker.max_actions, clock_ns() if clock_ns else 0)
        none_views = 0
        searched = SearchRun()
        view = None
        looked_in_vain = False  # a last look was in vain (see below): later last looks count as NONE
        while True:
            if tracker.actions >= tracker.max_actions:
                return TERMINATION_ACTION_LIMIT
            if tracker.consecutive_failures >= tracker.max_consecutive_failures:
                return tracker.termination()
            if self.stop():
                return TERMINATION_CANCELED
            if view is None:
                view = self._look()
            if view.mode == AttentionMode.NONE or (view.last_look and looked_in_vain):
                none_views += 1
                self.occluded_views = 0
                if none_views >= limits.none_frames_to_finish:
                    return TERMINATION_NOTHING_LEFT
                view = None  # look again: a fresh frame, taken after this one
                continue
            none_views = 0
            view = self._stall_look(view)
            occluded = view.mode == AttentionMode.OCCLUDED_REGION
            unexplored = self.memory.unexplored_area(view.height, hiding_height(limits.piece_height)) \
                if occluded else float("inf")
            searched.add(occluded, view.heap_height, low_heap_height(limits.piece_height), unexplored,
                         limits.impurity_area)
            if searched.over(limits.search_pushes, limits.low_heap_pushes):
                return TERMINATION_NOTHING_LEFT
            action = cell.decide(view)
            if action is None:
                return TERMINATION_NOTHING_LEFT
            if self.stop():
                return TERMINATION_CANCELED
            after, verdict = self._act_and_judge(view, action)
            # a last look answered by a push, or by a grasp the verdict says lifted no impurity, was in vain
            looked_in_vain = looked_in_vain or (view.last_look and not (verdict and verdict.impurity_picked))
            view = after

    def _act_and_judge(self, view: View, action: Action) -> tuple[View | None, GraspVerdict | None]:
        """run_by_perception's step: execute `action` (decided on `view`), judge a grasp on the next fresh
        view and record the step. Returns (that view, the next decision's; None after a push, the verdict
        or None). A cancel or an abort while looking after a grasp is raised once the step is recorded."""
        outcome = self.cell.execute(action)
        verdict, after, pending = None, None, None
        if action.kind == "grasp":
            try:  # the next fresh view judges the grasp, and is the next decision's view
                after = self._look()
            except (EpisodeCanceled, EpisodeAborted) as error:
                pending = error  # record the step (not judged), then end
            verdict = self._judge(view, after, outcome)
        truth_grasped = self._truth_of_grasp() if action.kind == "grasp" else None
        score = view.target_score if verdict is not None and view.mode == AttentionMode.TARGET else -1.0
        self._record(step_record(self.tracker.actions + 1, action, outcome, -1, 0, verdict=verdict,
                                 truth_target_grasped=truth_grasped, target_score=score))
        if pending is not None:
            raise pending
        return after, verdict

    def _judge(self, before: View, after: View | None, outcome: Outcome) -> GraspVerdict:
        gripper = GripperReport(outcome.holding, float(outcome.gripper_opening))
        if after is None:
            return GraspVerdict(False, -1.0, False, "not judged: no view after the grasp")
        mask = before.target_mask if before.mode == AttentionMode.TARGET else None
        return judge_grasp(before.height, before.color, mask, after.height, after.color, gripper,
                           self.limits.verdict, self.reference)

    def _truth_of_grasp(self) -> bool | None:
        """Did the grasp just recorded remove a target? From the cell's truth (None: it offers none)."""
        if self.truth_targets_total is None:
            return None
        truth = self._truth()
        if truth is None:
            return None
        removed, self._truth_removed = truth.targets_removed - self._truth_removed, truth.targets_removed
        return removed > 0
