"""UR5 kinematics (ur5_kinematics) and the motion plans of push and grasp primitives (motion)."""
