"""Evaluating many episodes: episodes, local and Ray backends, the result stream and summary, the
IK check."""
