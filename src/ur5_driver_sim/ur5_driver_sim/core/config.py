"""Simulator constants in one place: physics, colours, block sizes, gripper geometry, motion speeds.

Cell-wide geometry (workspace, camera, push length, gripper stroke) comes from impurity_common.cell;
what only the simulator needs lives here.
"""

from impurity_common import cell
from ur5_motion import ur5_kinematics

# Physics. 1/240 s steps: 1/120 s halves grasp success (DESIGN.md, measured).
TIME_STEP = 1.0 / 240.0
SOLVER_ITERATIONS = 20
GRAVITY = -9.81

# Colours (RGB 0..1). The same palette as the perception team's synthetic frames: grey table, blue
# product blocks with a small shade jitter, red impurities.
TABLE_COLOR = (150 / 255, 150 / 255, 150 / 255)
PRODUCT_COLOR = (40 / 255, 120 / 255, 200 / 255)
TARGET_COLOR = (220 / 255, 60 / 255, 40 / 255)
PRODUCT_SHADE_JITTER = 0.04  # +- per channel
GRIPPER_COLOR = ur5_kinematics.GRIPPER_COLOR
ARM_COLOR = ur5_kinematics.ARM_COLOR

# Table: a plain box whose top is cell.TABLE_Z, larger than the workspace so nothing falls at the edge.
TABLE_HALF_EXTENTS = (0.45, 0.45, 0.02)
TABLE_CENTER_XY = (0.5, 0.0)

# Blocks: contact parameters chosen so scenes settle and do not roll away.
BLOCK_DENSITY = 600.0  # kg/m^3, wood-like
BLOCK_LATERAL_FRICTION = 0.6
BLOCK_ROLLING_FRICTION = 0.003  # 1e-4 lets cylinders roll off the table and scenes never settle
BLOCK_SPINNING_FRICTION = 0.003
TABLE_LATERAL_FRICTION = 0.5

# Scene settling.
SETTLE_MAX_STEPS = 600
SETTLE_SPEED = 0.01  # m/s: every block slower than this -> settled
SETTLE_CHECK_EVERY = 20

# Gripper (RG2-like), shared by the floating gripper and the arm's end effector. Gripper frame: origin
# at the TCP (centre between the fingertips' lower ends), z up along the wrist, fingers close along x.
FINGER_LENGTH = cell.FINGER_LENGTH  # m, z extent of a finger pad
FINGER_THICKNESS = cell.FINGER_THICKNESS  # m, x extent
FINGER_WIDTH = cell.FINGER_WIDTH  # m, y extent
FINGER_MAX_TRAVEL = cell.GRIPPER_MAX_OPENING / 2.0  # inner face distance from the centre when open
PALM_HALF_EXTENTS = cell.PALM_HALF_EXTENTS
PALM_MASS = ur5_kinematics.PALM_MASS  # kg; the robot model's gripper body (URDF inertials, finger limits)
FINGER_MASS = ur5_kinematics.FINGER_MASS
FINGER_FORCE = ur5_kinematics.FINGER_FORCE  # N per finger
FINGER_SPEED = ur5_kinematics.FINGER_SPEED  # m/s per finger
FINGER_LATERAL_FRICTION = 1.2
FLANGE_TO_TCP = cell.FLANGE_TO_TCP  # m, UR flange to TCP along the tool axis (coupling + RG2 length)
CLOSED_OPENING = 0.004  # m: closer than this after closing -> nothing between the fingers

# Primitive motion: the plan's constants live in impurity_common.cell (the real driver runs the same
# plan, ur5_motion.motion); what only the simulator needs stays here.
APPROACH_HEIGHT = cell.APPROACH_HEIGHT  # m above the primitive's z where grasps and pushes start and end
SLOW_ZONE = cell.SLOW_ZONE  # m above z where descents slow down to CONTACT_SPEED
LIFT_HEIGHT = cell.LIFT_HEIGHT  # m: grasps lift this far; success needs >= GRASP_LIFT_SUCCESS
GRASP_LIFT_SUCCESS = cell.GRASP_LIFT_SUCCESS  # m: a grasp succeeded when the object rose this far
MIN_TIP_HEIGHT = cell.MIN_TIP_HEIGHT  # m: fingertips never go below table + this (z is clamped up)
FREE_SPEED = cell.FREE_SPEED  # m/s, moves in free space
CONTACT_SPEED = cell.CONTACT_SPEED  # m/s, the last SLOW_ZONE of descents, and pushes
LIFT_SPEED = cell.LIFT_SPEED  # m/s, lifting a grasped block
GUARD_FORCE = cell.GUARD_FORCE  # N: a descent stops when the gripper presses down harder than this
CLOSE_SETTLE_STEPS = 45  # steps given to the fingers to close (0.19 s)
RETREAT_SETTLE_STEPS = 60  # at most, after a primitive (ends early once every block rests)
CARRIER_MAX_FORCE = 500.0  # N, the floating gripper's drive constraint

# Ground truth.
DISPLACEMENT_CLASSES = (0.01, 0.05)  # m: < 1 cm "still", < 5 cm "nudged", else "moved"
