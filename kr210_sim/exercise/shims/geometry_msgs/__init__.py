"""The ROS package geometry_msgs: its messages, in ``geometry_msgs.msg``."""
