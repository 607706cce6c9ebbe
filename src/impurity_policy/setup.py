import glob

from setuptools import find_packages, setup

package_name = "impurity_policy"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        # the shipped network (when trained): found by policy_node in a ROS install
        ("share/" + package_name + "/checkpoints", glob.glob("checkpoints/*.pt")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Impurity cell team",
    maintainer_email="robotics@impurity-cell.dev",
    description="Push-grasp policy runtime: inference, test-time rules, the picking loop, the nodes.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "episode_node = impurity_policy.episode_node:main",
        "policy_node = impurity_policy.policy_node:main",
    ]},
)
