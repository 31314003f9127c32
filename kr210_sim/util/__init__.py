"""Plumbing every command shares: where files live, atomic outputs, the console, signals, progress
lines."""
