"""The ExecutePrimitive action on a real UR5 through ur-rtde, with a recording dry-run mode."""
