# Deployment image for a real cell: the runtime only. apt ROS 2 Jazzy, pip for what the runtime packages
# import (no PyBullet, no simulator, no training or evaluation code), the colcon-built runtime packages
# (impurity_interfaces, impurity_common, impurity_bags, impurity_calibration, impurity_viz, ur5_motion,
# impurity_attention, impurity_policy with its shipped checkpoint, ur5_driver_rtde, impurity_bringup with
# the launch file and parameter files), and an entrypoint that sources both, so
#   docker run --rm -it --network host --privileged <image> \
#       ros2 launch impurity_bringup cell.launch.py cell:=real
# works beside the RealSense driver (README, "Running on a real cell"). The simulated cell (`make demo`)
# runs from a clone with `make setup`, not from this image.
#
# Pins equal requirements.txt's where both name a package; each deviation says why
# (tests/workspace/test_dockerfile.py checks both). No Docker engine runs on our build machines: this
# file is linted (hadolint) and checked by that test in `make test`, never built there; its colcon step
# is: tests/workspace/test_image_install.py builds the same packages the same way (a colcon on another
# interpreter than the venv's, a plain install) and starts every runtime executable from that install.
FROM ros:jazzy-ros-base

SHELL ["/bin/bash", "-o", "pipefail", "-c"]

# torch's CPU-only wheels (a runtime cell infers on the CPU; PyPI's Linux torch carries CUDA, ~2.5 GB
# more). Pass --build-arg TORCH_INDEX_URL=https://pypi.org/simple for that build.
ARG TORCH_INDEX_URL=https://download.pytorch.org/whl/cpu
ENV DEBIAN_FRONTEND=noninteractive \
    FASTDDS_BUILTIN_TRANSPORTS=UDPv4 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    VIRTUAL_ENV=/opt/venv \
    PATH=/opt/venv/bin:$PATH \
    IMPURITY_CELL=real

# ROS packages come from apt (versions follow the Jazzy sync, hence unpinned). tf2_msgs and
# visualization_msgs are the real ones here: ros2_ws/fallback/tf2_msgs (for PyPI wheels) is not needed.
# The RealSense driver is the camera of the real cell (started apart: it needs the USB device).
# hadolint ignore=DL3008
RUN apt-get update \
    && apt-get install -y --no-install-recommends \
        python3-venv python3-pip python3-colcon-common-extensions \
        ros-jazzy-rosidl-default-generators ros-jazzy-sensor-msgs ros-jazzy-geometry-msgs \
        ros-jazzy-std-msgs ros-jazzy-std-srvs ros-jazzy-unique-identifier-msgs ros-jazzy-visualization-msgs \
        ros-jazzy-tf2-msgs ros-jazzy-rosgraph-msgs ros-jazzy-diagnostic-msgs \
        ros-jazzy-ros2launch ros-jazzy-launch-ros ros-jazzy-realsense2-camera \
    && rm -rf /var/lib/apt/lists/*

# Python packages in a venv, as the ROS 2 documentation ("Using Python Packages with ROS 2") has it: the
# venv sees apt's rclpy and message packages (--system-site-packages) and is first on PATH (ENV above);
# every package's setup.cfg says `[build_scripts] executable = /usr/bin/env python3`, so the executables
# that apt's colcon (on /usr/bin/python3) installs start on /opt/venv/bin/python3, which imports torch,
# OpenCV, scikit-learn, rosbags and ur-rtde. The venv lies outside /ws: colcon never crawls it.
# numpy==1.26.4, not requirements.txt's 2.4.6: the apt ROS message packages' C extensions were built
#   against Ubuntu 24.04's numpy 1.26 (an extension built for numpy 1.x does not load under numpy 2).
# opencv-python-headless==4.11.0.86, not requirements.txt's 5.0.0.93: 5.x and 4.12+ require numpy >= 2;
#   4.11 is the last for numpy 1.x and has cv2.aruco.CharucoDetector (>= 4.7) for calibrate_camera.
RUN python3 -m venv --system-site-packages /opt/venv \
    && pip install --index-url "${TORCH_INDEX_URL}" torch==2.13.0 \
    && pip install \
        numpy==1.26.4 \
        opencv-python-headless==4.11.0.86 \
        scikit-learn==1.9.1 \
        scipy==1.17.1 \
        PyYAML==6.0.3 \
        rosbags==0.11.9 \
        ur-rtde==1.6.5

WORKDIR /ws
COPY src/impurity_interfaces/ /ws/src/impurity_interfaces/
COPY src/impurity_common/ /ws/src/impurity_common/
COPY src/impurity_bags/ /ws/src/impurity_bags/
COPY src/impurity_calibration/ /ws/src/impurity_calibration/
COPY src/impurity_viz/ /ws/src/impurity_viz/
COPY src/ur5_motion/ /ws/src/ur5_motion/
COPY src/impurity_attention/ /ws/src/impurity_attention/
COPY src/impurity_policy/ /ws/src/impurity_policy/
COPY src/ur5_driver_rtde/ /ws/src/ur5_driver_rtde/
# impurity_bringup: cell.launch.py, config/, launch_cell and episode_client. Its demo and eval_graph
# modules are installed too but need the simulator, which is not: IMPURITY_CELL=real (ENV above) drops
# the simulated cell's packages from its package.xml dependencies.
COPY bringup/ /ws/src/impurity_bringup/
RUN . /opt/ros/jazzy/setup.bash \
    && colcon build --packages-select impurity_interfaces impurity_common impurity_bags impurity_calibration \
        impurity_viz ur5_motion impurity_attention impurity_policy ur5_driver_rtde impurity_bringup \
        --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE=/opt/venv/bin/python \
    && rm -rf build log

COPY bringup/docker_entrypoint.sh /docker_entrypoint.sh
ENTRYPOINT ["/docker_entrypoint.sh"]
CMD ["bash"]
