"""The exercise's ROS package ``kuka_arm``: its service, in ``kuka_arm.srv``."""
