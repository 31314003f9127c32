"""The ROS package std_msgs: its messages, in ``std_msgs.msg``."""
