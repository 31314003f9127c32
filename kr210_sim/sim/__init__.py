"""The stepped cell: MuJoCo's model and data under control, the runner that executes cycles,
targets."""
