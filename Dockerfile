# Deployment image for a real (or simulated) cell: apt ROS 2 Jazzy, pip for the learning and
# simulation stack, the colcon-built workspace, and an entrypoint that sources it so
# `ros2 run impurity_attention attention_node` and `ros2 service call` work.
#
# torch: PyPI's Linux torch wheel carries CUDA; for the CPU-only wheel pass the PyTorch CPU wheel
# index with --build-arg PIP_EXTRA_INDEX_URL=<index>. No Docker engine runs on our build machines:
# this file is linted (hadolint) in `make test`, not built there.
FROM ros:jazzy-ros-base

SHELL ["/bin/bash", "-o", "pipefail", "-c"]

ARG PIP_EXTRA_INDEX_URL=""
ENV DEBIAN_FRONTEND=noninteractive \
    FASTDDS_BUILTIN_TRANSPORTS=UDPv4 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    VIRTUAL_ENV=/opt/venv \
    PATH=/opt/venv/bin:$PATH

# ROS packages come from apt (versions follow the Jazzy sync, hence unpinned).
# hadolint ignore=DL3008
RUN apt-get update \
    && apt-get install -y --no-install-recommends \
        python3-venv python3-pip python3-colcon-common-extensions \
        ros-jazzy-rosidl-default-generators ros-jazzy-sensor-msgs ros-jazzy-geometry-msgs \
        ros-jazzy-rosbag2 ros-jazzy-rosbag2-storage-mcap ros-jazzy-ros2launch \
    && rm -rf /var/lib/apt/lists/*

# A venv that still sees apt's rclpy; numpy stays 1.x, the ABI the apt ROS packages were built against.
RUN python3 -m venv --system-site-packages /opt/venv \
    && pip install \
        torch==2.13.0 \
        pybullet==3.2.7 \
        numpy==1.26.4 \
        opencv-python-headless==4.10.0.84 \
        scikit-learn==1.5.2 \
        scipy==1.13.1 \
        matplotlib==3.9.2 \
        tqdm==4.67.1 \
        rosbags==0.11.9 \
        mcap==1.6.0

WORKDIR /ws
COPY src/ /ws/src/
RUN . /opt/ros/jazzy/setup.bash \
    && colcon build --cmake-args -DBUILD_TESTING=OFF -DPython3_EXECUTABLE=/opt/venv/bin/python \
    && rm -rf build log

COPY bringup/ /ws/bringup/
COPY bringup/docker_entrypoint.sh /docker_entrypoint.sh
ENTRYPOINT ["/docker_entrypoint.sh"]
CMD ["bash"]
