"""A picking episode's bookkeeping: request checks, metrics, termination, crash-safe records.

Shared by the episode node (ROS graph) and the fast-sim evaluation so both count the same way.
The paper's metrics (section 6.1): grasp success = targets picked / grasp attempts, action
efficiency = targets picked / actions (N_object / N_action for a completed episode).
"""

import dataclasses
import json
import os
import pathlib
import shutil
import time

import numpy as np

from impurity_common.enums import EPISODE_SCENARIOS

SCENARIOS = tuple(scenario.value for scenario in EPISODE_SCENARIOS)  # what an episode request may ask
# Paper section 6.4 caps real-world runs at 15 steps per group; we scale it with the target count
# so invisible scenes (more exploratory pushes) still have room: 15 actions per target.
DEFAULT_ACTIONS_PER_TARGET = 15
# A cell that cannot count targets (a real cell, use_ground_truth false) gets this action limit when a
# request's max_actions is 0: the paper's real-world runs stop at 15 steps per group of objects (section
# 6.4); two groups' worth.
DEFAULT_MAX_ACTIONS_UNCOUNTED = 30
# Without a target count the episode ends by perception: attention answers NONE (no visible impurity and
# no heap that could hide one) on this many consecutive fresh frames. One frame can miss a target
# (shading, a blurred edge): three in a row make the end robust at ~1 s of waiting.
DEFAULT_NONE_FRAMES_TO_FINISH = 3
# Counting by perception: pushes in a row at heaps with no impurity in view after which the bin is taken as
# clean (picking's end of the search): the least leaving at most 2 % of the impurities behind on the default
# palette's tuning episodes, by `python -m impurity_learning.calibrate search-pushes --palettes blocks` (its
# --seeds 6 run and a --scenarios invisible --seeds 12 run, pooled with --episodes): 30 episodes, 60
# impurities, reveals of 1 to 11 pushes; 6 leaves 1 of 60 behind, 5 leaves 3. Over the named and random tuning
# palettes as well (--seeds 12) 2 % needs 13 (5 % needs 8).
DEFAULT_SEARCH_PUSHES = 6
# The same at low heaps, lower than two pieces of DEFAULT_PIECE_HEIGHT: with search_pushes 6, the least within
# 2 % on the --seeds 6 run above (which records heap heights): 3 leaves none of its 11 reveals behind, 2 one.
DEFAULT_LOW_HEAP_PUSHES = 3
# One piece of the product (m): the simulator's blocks stand 30-45 mm (ur5_driver_sim.core.scenes), so a low
# heap is lower than 70 mm; low heaps of 60-75 mm gave the same figures on those episodes.
DEFAULT_PIECE_HEIGHT = 0.035
# The footprint of the smallest impurity (m^2): ground the episode has not seen down to the table, under
# material thicker than one piece, smaller than this hides none (picking's table memory). 5 cm^2, a 22 mm
# square: the simulator's smallest impurities are 26 mm cubes (ur5_driver_sim.core.scenes.HEAP_TARGET_EDGE).
DEFAULT_IMPURITY_AREA = 0.0005
# Consecutive grasps that lift nothing or pushes whose motion failed before giving up. A motion the
# driver refuses (goal rejected) is not one of them: it ends the episode at once ("error: ...").
DEFAULT_MAX_CONSECUTIVE_FAILURES = 5

TERMINATION_ALL_PICKED = "all_targets_picked"
# Every target in the workspace picked, but some lie outside it (from the start or pushed out): the
# summary's targets_outside says how many; such an episode is not completed.
TERMINATION_REACHABLE_PICKED = "all_reachable_targets_picked"
TERMINATION_ACTION_LIMIT = "action_limit"
TERMINATION_REPEATED_FAILURE = "repeated_failure"
TERMINATION_CANCELED = "canceled"
TERMINATION_NOTHING_LEFT = "no_target_or_cluster_left"
# How an episode counts picked impurities: the simulator's truth (a simulated cell's services), or the
# perception verdict on each grasp (core/verdict.py) on a cell without truth.
COUNTED_BY_TRUTH = "truth"
COUNTED_BY_PERCEPTION = "perception"
# An episode that ended before its scene was ready (canceled, refused or failed in the cell's reset) counted
# nothing: its record says so, with targets_total -1 (no count).
COUNTED_BY_NOTHING = "nothing"
# Reasons of episodes that ended because the cell failed, not because of the picking: "node_lost: ..."
# (a node stopped answering), "stale_input: ..." (inputs stamped on another clock), "unusable_input: ..."
# (camera frames the heightmap node drops: depth units, a camera pose that does not fit the table),
# "driver_lost: ..." (the arm driver lost the robot mid-motion), "error: ...".
FAILURE_PREFIXES = ("node_lost", "stale_input", "unusable_input", "driver_lost", "error")


def is_failure(termination_reason: str) -> bool:
    """True when an episode ended because the cell failed (FAILURE_PREFIXES), not by the picking."""
    return termination_reason.startswith(FAILURE_PREFIXES)


@dataclasses.dataclass
class EpisodeRequest:
    scenario: str = "random"
    seed: int = 0
    num_targets: int = 2
    num_objects: int = 20
    max_actions: int = 0
    scene_file: str = ""
    palette: str = ""  # simulated cell only: the scene's appearance ("" = default palette)


# The range of each numeric request field, as the messages carry it (StartEpisode, RunEpisode: seed is a
# uint32, the counts int32), narrowed to what an episode can use: (lowest, highest).
UINT32_MAX = 2**32 - 1
INT32_MAX = 2**31 - 1
FIELD_RANGES = {"seed": (0, UINT32_MAX), "num_targets": (1, INT32_MAX), "num_objects": (0, INT32_MAX),
                "max_actions": (0, INT32_MAX)}
_RANGE_NOTES = {"max_actions": "; 0 means the default"}


def validate_request(request: EpisodeRequest) -> str | None:
    """None when the request can run, else the reason it is refused (one line, naming the field).

    The one check of an episode request: the episode node applies it to /episode/start and /episode/run
    alike, and impurity_bringup.episode_client before it sends one. Refused: an unknown scenario; a numeric
    field outside FIELD_RANGES; more targets than product blocks (num_targets > num_objects: a scene of
    impurities among a few blocks of product is not a sorting job; the scenario 'file' takes its counts
    from the file and is exempt); scenario 'file' without an existing scene_file (a path on the episode
    node's machine). Limits of one cell (a simulated cell's block count, the heaps of 'invisible') are
    that cell's to refuse at the scene reset."""
    if request.scenario not in SCENARIOS:
        return f"unknown scenario '{request.scenario}' (expected one of {', '.join(SCENARIOS)})"
    for name, (low, high) in FIELD_RANGES.items():
        value = getattr(request, name)
        if value < low:
            return f"{name} must be >= {low} (got {value}{_RANGE_NOTES.get(name, '')})"
        if value > high:
            return f"{name} must be <= {high} (got {value})"
    if request.scenario != "file" and request.num_targets > request.num_objects:
        return (f"num_targets ({request.num_targets}) must not exceed num_objects ({request.num_objects}): "
                "an episode picks a few impurities out of the product")
    if request.scenario == "file":
        if not request.scene_file:
            return "scenario 'file' needs scene_file"
        if not pathlib.Path(request.scene_file).is_file():
            return f"scene_file '{request.scene_file}' does not exist"
    return None


def describe_request(request: EpisodeRequest) -> str:
    """The request in one line for logs and consoles, e.g. "random seed 3, palette coal_slate, 2 target(s)
    among 20 object(s)"; the palette always shown ("default" when empty), a scene file instead of counts."""
    palette = request.palette or "default"
    what = (f"scene {request.scene_file}" if request.scenario == "file" else
            f"{request.num_targets} target(s) among {request.num_objects} object(s)")
    limit = f", at most {request.max_actions} actions" if request.max_actions else ""
    return f"{request.scenario} seed {request.seed}, palette {palette}, {what}{limit}"


def action_limit(request: EpisodeRequest, targets_total: int,
                 actions_per_target: int = DEFAULT_ACTIONS_PER_TARGET) -> int:
    return request.max_actions if request.max_actions > 0 else actions_per_target * max(1, targets_total)


@dataclasses.dataclass
class StepRecord:
    """One executed action, as written to steps.jsonl."""

    step: int
    attention_mode: str  # TARGET, OCCLUDED_REGION, NONE
    kind: str  # push | grasp
    position: tuple  # base_link (m)
    yaw: float
    q_value: float
    rotation_index: int
    pixel: tuple  # heightmap (row, col)
    decision_stamp_ns: int  # camera frame the decision came from
    motion_finished_ns: int  # when the driver reported the motion done
    success: bool  # grasp: lifted something; push: motion completed
    target_grasped: bool
    object_grasped: bool
    targets_remaining: int  # in the workspace
    message: str = ""
    targets_outside: int = 0  # in the scene but outside the workspace (not reachable)
    # What the arm reported (ExecutePrimitive): the whole plan ran; m between the fingers after the lift
    # (-1 not measured); something held.
    motion_completed: bool = True
    gripper_opening: float = -1.0
    holding: bool = False
    # Perception verdict on a grasp (counted_by "perception"): share of the attended target's cells that
    # changed (-1: not judged) and the verdict's reason. target_grasped is then the verdict.
    gone_fraction: float = -1.0
    verdict: str = ""
    target_score: float = -1.0  # the judged grasp's TARGET: attention's contrast (-1: not judged)
    # Simulator truth beside the verdict (only where the cell offers it; never used by the loop): the grasp
    # removed a target (None: no truth, or not a grasp).
    truth_target_grasped: bool | None = None


class CountError(ValueError):
    """A step's counts contradict the episode's: more targets picked, left or outside than there were."""


class EpisodeTracker:
    """Counts an episode's actions and decides when it ends.

    Targets are counted apart by where they are: picked, remaining (in the workspace, still to pick) and
    outside (in the scene but outside the workspace: from the start, or pushed out). Invariant, checked on
    every step: picked + remaining + outside <= targets_total, so no metric shows more picked than there
    were."""

    def __init__(self, episode_id: str, request: EpisodeRequest, targets_total: int,
                 max_actions: int, max_consecutive_failures: int = DEFAULT_MAX_CONSECUTIVE_FAILURES,
                 counts_known: bool = True):
        self.counts_known = counts_known  # False: a cell without target counts (counted by perception)
        self.episode_id = episode_id
        self.request = request
        self.targets_total = targets_total
        self.max_actions = max_actions
        self.max_consecutive_failures = max_consecutive_failures
        self.steps: list[StepRecord] = []
        self.targets_picked = 0
        self.grasp_attempts = 0
        self.grasp_successes = 0
        self.pushes = 0
        self.false_rejects = 0
        self.consecutive_failures = 0
        self.targets_remaining = targets_total
        self.targets_outside = 0

    @property
    def actions(self) -> int:
        return len(self.steps)

    def set_scene(self, in_workspace: int, outside: int = 0) -> None:
        """The scene the cell built: targets in the workspace and outside it; their sum is the total."""
        if in_workspace < 0 or outside < 0:
            raise CountError(f"negative target counts from the cell: {in_workspace} in the workspace, "
                             f"{outside} outside")
        self.targets_total = in_workspace + outside
        self.targets_remaining, self.targets_outside = in_workspace, outside

    def record(self, step: StepRecord) -> None:
        """Count one step; CountError (nothing counted) when its counts contradict the episode's. Without
        target counts (counts_known False) the step's targets_remaining is -1 and is not checked."""
        picked = self.targets_picked + (1 if step.kind == "grasp" and step.target_grasped else 0)
        if self.counts_known and (step.targets_remaining < 0 or step.targets_outside < 0):
            raise CountError(f"step {step.step}: negative target counts ({step.targets_remaining} left in "
                             f"the workspace, {step.targets_outside} outside it): the cell counts targets "
                             "wrongly")
        if self.counts_known and picked + step.targets_remaining + step.targets_outside > self.targets_total:
            raise CountError(
                f"step {step.step}: {picked} picked + {step.targets_remaining} left in the workspace + "
                f"{step.targets_outside} outside it is more than the {self.targets_total} target(s) the "
                "scene held (the cell counts targets wrongly)")
        self.steps.append(step)
        self.targets_remaining, self.targets_outside = step.targets_remaining, step.targets_outside
        if step.kind == "grasp":
            self.grasp_attempts += 1
            if step.success:
                self.grasp_successes += 1
            if step.target_grasped:
                self.targets_picked += 1
            elif step.object_grasped:
                self.false_rejects += 1
            self.consecutive_failures = 0 if step.success else self.consecutive_failures + 1
        else:
            self.pushes += 1
            if not step.success:
                self.consecutive_failures += 1

    def termination(self) -> str | None:
        """Why the episode should stop now, or None to go on."""
        if self.counts_known and self.targets_remaining <= 0:
            return TERMINATION_ALL_PICKED if self.targets_outside == 0 else TERMINATION_REACHABLE_PICKED
        if self.actions >= self.max_actions:
            return TERMINATION_ACTION_LIMIT
        if self.consecutive_failures >= self.max_consecutive_failures:
            return TERMINATION_REPEATED_FAILURE
        return None

    def metrics(self) -> dict:
        return {
            "episode_id": self.episode_id,
            "targets_total": self.targets_total,
            "targets_picked": self.targets_picked,
            "targets_outside": self.targets_outside,
            "grasp_attempts": self.grasp_attempts,
            "grasp_successes": self.grasp_successes,
            "pushes": self.pushes,
            "actions": self.actions,
            "false_rejects": self.false_rejects,
            "grasp_success": self.targets_picked / self.grasp_attempts if self.grasp_attempts else 0.0,
            "action_efficiency": self.targets_picked / self.actions if self.actions else 0.0,
        }


def truth_audit(steps: list[StepRecord], truth_targets_total: int | None = None) -> dict:
    """Perception verdicts beside the simulator's truth, for an episode counted by perception on a cell
    that offers truth (scoring beside the loop: nothing here steers it).

    Returns verdicts_checked (grasps with a truth), verdicts_agreeing (verdict == truth), verdict_agreement
    (their ratio; None without any), truth_targets_picked (-1 without truth), truth_targets_total (-1
    unknown) and picked_matches_truth (perception's picked count == the truth's; None without truth).
    """
    judged = [s for s in steps if s.kind == "grasp" and s.truth_target_grasped is not None]
    agreeing = sum(bool(s.target_grasped) == bool(s.truth_target_grasped) for s in judged)
    has_truth = truth_targets_total is not None
    truth_picked = sum(bool(s.truth_target_grasped) for s in judged) if has_truth else -1
    picked = sum(bool(s.target_grasped) for s in steps if s.kind == "grasp")
    return {"verdicts_checked": len(judged), "verdicts_agreeing": agreeing,
            "verdict_agreement": agreeing / len(judged) if judged else None,
            "truth_targets_picked": truth_picked,
            "truth_targets_total": truth_targets_total if has_truth else -1,
            "picked_matches_truth": (picked == truth_picked) if has_truth else None}


class EpisodeRecorder:
    """Appends every step and the summary to disk as they happen (flushed and fsynced), so a crash
    of any node loses nothing already done.

    Layout: <record_root>/<episode_id>/ holds steps.jsonl (start, steps, end) and summary.json;
    <record_root>/episodes.jsonl indexes every summary. With `request`, the summary carries it (scenario,
    seed, palette, counts) under "request"."""

    def __init__(self, record_root: str | os.PathLike, episode_id: str,
                 request: EpisodeRequest | None = None):
        self.root = pathlib.Path(record_root)
        self.directory = self.root / episode_id
        self.directory.mkdir(parents=True, exist_ok=True)
        self.steps_path = self.directory / "steps.jsonl"
        self.summary_path = self.directory / "summary.json"
        self.request = request

    def discard(self) -> None:
        """Remove the episode's folder (an episode refused at its start: it never ran). Its line in the
        index, if written, stays: the refusal's reason, with a record_path that no longer exists."""
        shutil.rmtree(self.directory, ignore_errors=True)

    @staticmethod
    def _append_line(path: pathlib.Path, record: dict) -> None:
        with open(path, "a") as stream:
            stream.write(json.dumps(record, sort_keys=True) + "\n")
            stream.flush()
            os.fsync(stream.fileno())

    def write_start(self, request: EpisodeRequest, targets_total: int, max_actions: int,
                    scene_ready_ns: int, targets_outside: int = 0) -> None:
        """scene_ready_ns: the clock time after which camera frames show the episode's scene;
        targets_outside: how many of targets_total lie outside the workspace."""
        self._append_line(self.steps_path, {"event": "start", "wall_time": time.time(),
                                            "request": dataclasses.asdict(request),
                                            "targets_total": targets_total,
                                            "targets_outside": targets_outside, "max_actions": max_actions,
                                            "scene_ready_ns": scene_ready_ns})

    def write_step(self, step: StepRecord) -> None:
        self._append_line(self.steps_path, {"event": "step", **dataclasses.asdict(step)})

    def write_first_view(self, color: np.ndarray) -> None:
        """The episode's first colour heightmap (H, W, 3) uint8 RGB, the background of its picture."""
        import cv2

        cv2.imwrite(str(self.directory / "first_heightmap.png"), np.ascontiguousarray(color[:, :, ::-1]))

    def write_picture(self) -> pathlib.Path | None:
        """episode.png: the first heightmap with every executed primitive drawn (draw_episode); None
        when no first view was written."""
        import cv2

        first = self.directory / "first_heightmap.png"
        if not first.exists():
            return None
        steps = [r for r in read_steps(self.steps_path) if r.get("event") == "step"]
        picture = draw_episode(cv2.imread(str(first))[:, :, ::-1], steps)
        path = self.directory / "episode.png"
        cv2.imwrite(str(path), picture[:, :, ::-1])
        return path

    def write_summary(self, metrics: dict, termination_reason: str) -> dict:
        summary = {**metrics, "termination_reason": termination_reason, "wall_time": time.time(),
                   "record_path": str(self.directory)}
        if self.request is not None:
            summary["request"] = dataclasses.asdict(self.request)
        self._append_line(self.steps_path, {"event": "end", **summary})
        tmp = self.summary_path.with_suffix(".tmp")
        tmp.write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n")
        tmp.replace(self.summary_path)
        self._append_line(self.root / "episodes.jsonl", summary)
        return summary


def read_steps(steps_path: str | os.PathLike) -> list[dict]:
    """The records of steps.jsonl; a line cut short by a crash is skipped, never fatal."""
    records = []
    for line in pathlib.Path(steps_path).read_text().splitlines():
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return records


def draw_episode(color_heightmap: np.ndarray, steps: list[dict], overlay: np.ndarray | None = None,
                 scale: int = 3) -> np.ndarray:
    """The first heightmap (optionally blended with the attention overlay) with every executed
    primitive drawn and numbered: arrows for pushes, a jaw bar for grasps (green if it lifted a
    target, orange for a non-target, red if it failed)."""
    import cv2

    from impurity_common.cell import HEIGHTMAP_RESOLUTION, PUSH_LENGTH

    image = color_heightmap.astype(np.float32)
    if overlay is not None and overlay.shape == color_heightmap.shape:
        image = 0.5 * image + 0.5 * overlay.astype(np.float32)
    image = cv2.resize(image.astype(np.uint8), None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    image = np.ascontiguousarray(image[:, :, ::-1])  # cv2 draws in BGR
    push_px = PUSH_LENGTH / HEIGHTMAP_RESOLUTION * scale
    jaw_px = 0.04 / HEIGHTMAP_RESOLUTION * scale
    for record in steps:
        row, col = record["pixel"]
        centre = np.array([(col + 0.5) * scale, (row + 0.5) * scale])
        direction = np.array([np.cos(record["yaw"]), np.sin(record["yaw"])])  # +x -> +col, +y -> +row
        if record["kind"] == "push":
            color = (255, 200, 0)
            tip = centre + push_px * direction
            cv2.arrowedLine(image, tuple(int(v) for v in centre), tuple(int(v) for v in tip), color, 2,
                            tipLength=0.2)
        else:
            color = (0, 200, 0) if record["target_grasped"] else (
                (0, 140, 255) if record["object_grasped"] else (0, 0, 255))
            a, b = centre - jaw_px * direction, centre + jaw_px * direction
            cv2.line(image, tuple(int(v) for v in a), tuple(int(v) for v in b), color, 3)
            cv2.circle(image, tuple(int(v) for v in centre), 4, color, -1)
        cv2.putText(image, str(record["step"]), (int(centre[0]) + 6, int(centre[1]) - 6),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(image, str(record["step"]), (int(centre[0]) + 6, int(centre[1]) - 6),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 1, cv2.LINE_AA)
    return np.ascontiguousarray(image[:, :, ::-1])
