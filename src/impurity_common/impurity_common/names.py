"""Every ROS name of the cell, declared once: topics, services, actions and frame ids.

Nodes, launchers, scripts and tests import these instead of spelling names. The cell's names are
relative: a node started in a namespace (`--ros-args -r __ns:=/cell_a`, the launchers' `namespace`) has
them under it (/cell_a/heightmap), so two cells run side by side; without one they resolve to the root
(/heightmap). TF stays global (/tf, /tf_static), as ROS tools expect. One name renames with ROS
remapping (`-r heightmap:=/other/heightmap`), never by editing code. The camera topics are the
realsense2_camera driver's defaults (namespace and name `camera`, under the cell's namespace); frames follow
REP-103.
"""

# Frames
BASE_FRAME = "base_link"  # the UR5 base: x forward, y left, z up; the table top at cell.TABLE_Z
CAMERA_OPTICAL_FRAME = "camera_color_optical_frame"  # z out of the lens, x right, y down

# Camera (RealSense driver, or the simulated one in ur5_driver_sim)
COLOR_TOPIC = "camera/camera/color/image_raw"  # sensor_msgs/Image rgb8
DEPTH_TOPIC = "camera/camera/aligned_depth_to_color/image_raw"  # sensor_msgs/Image 16UC1 mm or 32FC1 m
CAMERA_INFO_TOPIC = "camera/camera/color/camera_info"  # sensor_msgs/CameraInfo

# Perception
HEIGHTMAP_TOPIC = "heightmap"  # impurity_interfaces/Heightmap
# std_msgs/String: why the heightmap node dropped a camera frame as unusable (depth units, the table not where
# the camera pose puts it, a bad image), one message per frame dropped; the episode node ends on them
HEIGHTMAP_DROPPED_TOPIC = "heightmap/dropped"
ATTENTION_TOPIC = "attention/result"  # impurity_interfaces/AttentionResult
ATTENTION_DEBUG_TOPIC = "attention/debug_image"  # sensor_msgs/Image rgb8, the saliency overlay
# impurity_interfaces/Heightmap, transient local: the episode's first view when attention found no target in
# it (the known product, core/picking.py); an empty heightmap (no cells) at each episode's reset clears it
KNOWN_PRODUCT_TOPIC = "attention/known_product"
# std_srvs/srv/SetBool: true - the attention node attends the frames that follow as a stall look (attend's
# closer: the verifier model's stall_look, checkpoints/verifier.json) until set false; the episode node asks
# for one (impurity_policy/core/picking.py)
LOOK_CLOSER_SERVICE = "attention/look_closer"

# Decisions and episodes
PRIMITIVE_TOPIC = "policy/primitive"  # impurity_interfaces/Primitive
Q_MAPS_TOPIC = "policy/q_maps_image"  # sensor_msgs/Image rgb8, the Q maps side by side
EPISODE_STEPS_TOPIC = "episode/steps"  # impurity_interfaces/EpisodeStep
START_EPISODE_SERVICE = "episode/start"  # impurity_interfaces/srv/StartEpisode
RUN_EPISODE_ACTION = "episode/run"  # impurity_interfaces/action/RunEpisode
STOP_EPISODE_SERVICE = "episode/stop"  # std_srvs/srv/Trigger: the running episode ends "canceled"
EPISODE_STATUS_SERVICE = "episode/status"  # std_srvs/srv/Trigger: could an episode start now (else why)

# Robot (the UR and gripper drivers, or sim_cell)
EXECUTE_PRIMITIVE_ACTION = "ur5/execute_primitive"  # impurity_interfaces/action/ExecutePrimitive
JOINT_STATES_TOPIC = "joint_states"  # sensor_msgs/JointState

# What RViz and Foxglove show (cell_state_publisher, decision_markers)
TF_TOPIC = "/tf"  # tf2_msgs/TFMessage: base_link -> the UR5 links, tool0, the gripper TCP
TF_STATIC_TOPIC = "/tf_static"  # tf2_msgs/TFMessage, transient local: fixed joints, the camera pose
ROBOT_DESCRIPTION_TOPIC = "robot_description"  # std_msgs/String URDF, transient local
MARKERS_TOPIC = "cell/markers"  # visualization_msgs/MarkerArray: chosen push/grasp, attended region

# Every node's status, once a second (impurity_common/diagnostics.py)
DIAGNOSTICS_TOPIC = "/diagnostics"  # diagnostic_msgs/DiagnosticArray

# Simulator only
RESET_SCENE_SERVICE = "cell/reset_scene"  # impurity_interfaces/srv/ResetScene
GROUND_TRUTH_SERVICE = "cell/ground_truth"  # impurity_interfaces/srv/GetGroundTruth

# What a recording of an episode holds (bag_recorder's default): the camera in, the frames dropped and
# why, every decision out, and what a 3-D view of the bag needs (TF, the robot model, the markers;
# /tf_static, /robot_description, /cell/markers and /attention/known_product are transient local: the
# recorder asks for that when every publisher offers it, so the latched messages published before it
# started are in the bag too).
EPISODE_TOPICS = (COLOR_TOPIC, DEPTH_TOPIC, CAMERA_INFO_TOPIC, HEIGHTMAP_TOPIC, HEIGHTMAP_DROPPED_TOPIC,
                  KNOWN_PRODUCT_TOPIC, ATTENTION_TOPIC, PRIMITIVE_TOPIC, EPISODE_STEPS_TOPIC,
                  JOINT_STATES_TOPIC, TF_TOPIC, TF_STATIC_TOPIC, ROBOT_DESCRIPTION_TOPIC, MARKERS_TOPIC)


def absolute(name: str, namespace: str = "/") -> str:
    """`name` as ROS resolves it in `namespace` (no remapping): a relative name under the namespace, an
    absolute one as it is. What a graph query or a bag (recorded names are absolute) spells:
    absolute(HEIGHTMAP_TOPIC) == "/heightmap", absolute(HEIGHTMAP_TOPIC, "/cell_a") == "/cell_a/heightmap"."""
    if name.startswith("/"):
        return name
    return f"{namespace.rstrip('/')}/{name}"
