"""The cell: its specification, cell files (TOML), the MJCF builder, dressing, and the layout read
back from a model."""
