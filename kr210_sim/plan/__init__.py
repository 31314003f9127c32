"""Planning a cycle: gripper poses to joint waypoints, collision checks, timed trajectories, and
the cell check."""
