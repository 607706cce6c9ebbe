"""Rank-based prioritized experience replay (Schaul et al. 2016, "stochastic rank-based"), in memory
with a size cap, saved to one file for resumable training (never committed).

A transition keeps what the trainer needs to recompute its TD target with the current target network:
the state's crops, the action (primitive, rotation, crop pixel), the reward, the next state's crops
(None when the episode ended there) and which primitives were allowed in the next state. Crops are
zlib-compressed (a 112^2 state is ~75 kB raw, a few kB compressed), so 20 000 transitions fit in a few
hundred MB.

Priority = |TD error| of the last time the transition was used (new ones get the current maximum).
Sampling: sort by priority, draw rank r (1 = largest) with P(r) ~ r^-alpha.
"""

from __future__ import annotations

import pathlib
import pickle
import zlib
from dataclasses import dataclass

import numpy as np

from impurity_policy.core.decision import State

REPLAY_FORMAT_VERSION = 1
DEFAULT_CAPACITY = 20000
DEFAULT_ALPHA = 0.7  # rank exponent (Schaul et al.)


@dataclass
class Transition:
    state: State
    primitive: int  # network.PUSH / GRASP
    rotation: int
    pixel: tuple  # (row, col) in the crop
    reward: float
    next_state: State | None  # None: terminal (no future reward)
    next_allowed: tuple = (0, 1)  # primitives the policy may choose in the next state


def _pack_state(state: State | None):
    if state is None:
        return None
    return (zlib.compress(np.ascontiguousarray(state.color, np.uint8).tobytes(), 1),
            zlib.compress(np.ascontiguousarray(state.height, np.float16).tobytes(), 1),
            zlib.compress(np.ascontiguousarray(state.mask, np.uint8).tobytes(), 1),
            state.mask.shape[0])


def _unpack_state(packed) -> State | None:
    if packed is None:
        return None
    color, height, mask, size = packed
    return State(color=np.frombuffer(zlib.decompress(color), np.uint8).reshape(size, size, 3).copy(),
                 height=np.frombuffer(zlib.decompress(height), np.float16).reshape(size, size)
                 .astype(np.float32),
                 mask=np.frombuffer(zlib.decompress(mask), np.uint8).reshape(size, size).copy())


class RankedReplay:
    def __init__(self, capacity: int = DEFAULT_CAPACITY, alpha: float = DEFAULT_ALPHA):
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.capacity, self.alpha = capacity, alpha
        self._items: list = []  # packed transitions, a ring once full
        self._priority = np.zeros(capacity, dtype=np.float64)
        self._primitive = np.zeros(capacity, dtype=np.int8)
        self._positive = np.zeros(capacity, dtype=bool)
        self._next = 0

    def __len__(self) -> int:
        return len(self._items)

    def add(self, transition: Transition) -> int:
        packed = (_pack_state(transition.state), transition.primitive, transition.rotation,
                  tuple(int(v) for v in transition.pixel), float(transition.reward),
                  _pack_state(transition.next_state), tuple(transition.next_allowed))
        index = self._next
        if index < len(self._items):
            self._items[index] = packed
        else:
            self._items.append(packed)
        self._priority[index] = self._priority[:len(self._items)].max(initial=1.0)
        self._primitive[index] = transition.primitive
        self._positive[index] = transition.reward > 0
        self._next = (index + 1) % self.capacity
        return index

    def get(self, index: int) -> Transition:
        state, primitive, rotation, pixel, reward, next_state, allowed = self._items[index]
        return Transition(_unpack_state(state), primitive, rotation, pixel, reward,
                          _unpack_state(next_state), allowed)

    def update_priority(self, index: int, td_error: float) -> None:
        self._priority[index] = abs(float(td_error)) + 1e-6

    def sample(self, rng: np.random.Generator, primitive: int | None = None,
               positive: bool | None = None, exclude: int | None = None) -> int | None:
        """Index of one transition drawn by rank (optionally only one primitive / outcome, as VPG
        replays the same primitive with the opposite outcome); None when nothing matches."""
        candidates = np.arange(len(self._items))
        keep = np.ones(len(candidates), dtype=bool)
        if primitive is not None:
            keep &= self._primitive[:len(candidates)] == primitive
        if positive is not None:
            keep &= self._positive[:len(candidates)] == positive
        if exclude is not None and exclude < len(candidates):
            keep[exclude] = False
        candidates = candidates[keep]
        if len(candidates) == 0:
            return None
        order = candidates[np.argsort(-self._priority[candidates], kind="stable")]
        weights = 1.0 / np.arange(1, len(order) + 1) ** self.alpha
        return int(order[rng.choice(len(order), p=weights / weights.sum())])

    def save(self, path) -> None:
        """Atomic, like the checkpoint: a run killed while saving keeps the previous buffer intact."""
        path = pathlib.Path(path)
        tmp = path.with_suffix(path.suffix + ".tmp")
        with open(tmp, "wb") as f:
            pickle.dump({"version": REPLAY_FORMAT_VERSION, "capacity": self.capacity, "alpha": self.alpha,
                         "items": self._items, "priority": self._priority, "primitive": self._primitive,
                         "positive": self._positive, "next": self._next}, f, protocol=pickle.HIGHEST_PROTOCOL)
        tmp.replace(path)

    @classmethod
    def load(cls, path) -> RankedReplay:
        with open(path, "rb") as f:
            data = pickle.load(f)
        if data.get("version") != REPLAY_FORMAT_VERSION:
            raise ValueError(f"replay file {path} has format version {data.get('version')}, "
                             f"this code reads version {REPLAY_FORMAT_VERSION}")
        replay = cls(data["capacity"], data["alpha"])
        replay._items, replay._priority = data["items"], data["priority"]
        replay._primitive, replay._positive, replay._next = data["primitive"], data["positive"], data["next"]
        return replay
