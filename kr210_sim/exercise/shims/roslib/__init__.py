"""roslib, as old ROS scripts start: ``roslib.load_manifest(package)`` (nothing to load here)."""


def load_manifest(package: str) -> None:
    """Nothing to load: the modules a manifest put on the path are here already."""


__all__ = ["load_manifest"]
