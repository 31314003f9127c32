"""Evaluating many episodes: episodes, local and Ray backends, the result stream and summary, the
IK check, and grading a class of IK solutions (grade, student, diagnose, leaderboard)."""
