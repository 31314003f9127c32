"""The ROS package sensor_msgs: its messages, in ``sensor_msgs.msg``."""
