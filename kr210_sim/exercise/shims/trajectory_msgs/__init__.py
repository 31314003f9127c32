"""The ROS package trajectory_msgs: its messages, in ``trajectory_msgs.msg``."""
