"""The KR210 itself: its description read from the URDF, closed-form kinematics, meshes, and a
user's IK."""
