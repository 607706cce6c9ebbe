"""Episode bags: the bag core (bags), the recorder and replay nodes."""
