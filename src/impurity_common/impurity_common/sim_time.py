"""Simulated time without a /clock: the nodes refuse to judge inputs on a clock that stands at 0.

A node started with `use_sim_time:=true` reads its time from /clock; until a /clock message arrives its
clock reads 0, so every age check (`now - stamp`) comes out negative and passes everything, and nothing
downstream can tell. The heightmap, attention and policy nodes ask a `StoppedClockGate` before they use
an input: while that clock stands at 0 the input is dropped, and the reason is logged once.
"""

STOPPED_CLOCK_REASON = (
    "use_sim_time is true and no /clock has arrived: this node's clock stands at 0 s, so no input's age can "
    "be judged and inputs are dropped until /clock runs. Publish /clock (bag_replay -p clock:=true, "
    "`ros2 bag play --clock`, a simulator) or start the node with use_sim_time:=false")


def stopped_clock_reason(sim_time: bool, now_ns: int) -> str | None:
    """Why an input cannot be judged on this clock (`sim_time`: the node's use_sim_time is in effect;
    `now_ns`: its clock's reading, ns), or None when the clock can be used."""
    return STOPPED_CLOCK_REASON if sim_time and now_ns == 0 else None


class StoppedClockGate:
    """One per node: `stopped()` is true while the node's clock is simulated and has not received /clock
    (stopped_clock_reason), and says so in the node's log the first time (one warning line)."""

    def __init__(self, node):
        self._node = node
        self._said = False

    def stopped(self) -> bool:
        clock = self._node.get_clock()
        sim_time = bool(getattr(clock, "ros_time_is_active", False))
        reason = stopped_clock_reason(sim_time, clock.now().nanoseconds if sim_time else -1)
        if reason is None:
            return False
        if not self._said:
            self._said = True
            self._node.get_logger().warning(f"input dropped: {reason}. (Said once.)")
        return True
