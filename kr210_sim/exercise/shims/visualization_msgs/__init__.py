"""The ROS package visualization_msgs: its messages, in ``visualization_msgs.msg``."""
