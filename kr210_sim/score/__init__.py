"""What a cycle's observations mean: the outcome and its detail, metrics, and the report schema."""
