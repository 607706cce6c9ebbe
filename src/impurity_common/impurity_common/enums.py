"""The cell's enumerations, declared once (pure Python, no rclpy).

AttentionMode and PrimitiveKind have the integer values of the message constants
(impurity_interfaces AttentionResult.MODE_*, Primitive.PUSH/GRASP; PrimitiveKind is also the primitive's
index in Q-map tensors), so members compare equal to message fields: `msg.kind == PrimitiveKind.GRASP`,
`AttentionMode(msg.mode).name`. Scenario's values are the strings of requests and parameters.

Every enum has `parse(text)`: a name (case-insensitive, e.g. "grasp", "TARGET", "random") -> the member,
ValueError listing the known names otherwise.
"""

import enum
import re


class _Parse:
    """`parse` and `label` for the cell's enums (a mix-in: no members, no data type)."""

    @classmethod
    def _what(cls) -> str:
        return re.sub(r"(?<!^)(?=[A-Z])", " ", cls.__name__).lower()  # PrimitiveKind -> primitive kind

    @classmethod
    def known(cls) -> tuple:
        return tuple(member.label for member in cls)

    @classmethod
    def parse(cls, text: str, allowed=None):
        """The member called `text` (case-insensitive); `allowed` narrows the members accepted.
        ValueError: "unknown scenario 'tidy' (expected one of random, challenging, ...)"."""
        members = tuple(allowed) if allowed is not None else tuple(cls)
        key = str(text).strip().lower()
        for member in members:
            if member.label == key:
                return member
        raise ValueError(f"unknown {cls._what()} {str(text)!r} "
                         f"(expected one of {', '.join(m.label for m in members)})")

    @property
    def label(self) -> str:
        """The lower-case name used in logs, records and parameters: "push", "occluded_region"."""
        return self.name.lower()


class AttentionMode(_Parse, enum.IntEnum):
    """What the attention module centred its crops on (AttentionResult.MODE_*)."""

    NONE = 0  # no salient target and no dense cluster: nothing left to look for
    TARGET = 1  # a visible target: crops centred on the most salient region m_t
    OCCLUDED_REGION = 2  # no visible target: crops centred on the densest cluster c_t


class PrimitiveKind(_Parse, enum.IntEnum):
    """A motion primitive (Primitive.PUSH/GRASP), also its index in Q-map tensors."""

    PUSH = 0  # close fingers, descend, move cell.PUSH_LENGTH along yaw, lift
    GRASP = 1  # open, descend, close across yaw, lift


class Scenario(_Parse, enum.StrEnum):
    """A scene layout (paper 6.1) the simulator builds; its value is the requests' string."""

    RANDOM = "random"  # blocks dropped around the workspace centre
    CHALLENGING = "challenging"  # a packed grid of blocks
    INVISIBLE = "invisible"  # targets hidden under heaps: none visible at the start
    FILE = "file"  # blocks from a JSON scene file
    EMPTY = "empty"  # nothing on the table (sim checks only; episodes refuse it)

    @property
    def label(self) -> str:
        return self.value


# The scenarios an episode can run (an empty table has nothing to pick).
EPISODE_SCENARIOS = (Scenario.RANDOM, Scenario.CHALLENGING, Scenario.INVISIBLE, Scenario.FILE)
