from setuptools import find_packages, setup

package_name = "impurity_common"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Impurity cell team",
    maintainer_email="robotics@impurity-cell.dev",
    description="Cell geometry constants, message conversions, the node main idiom, bag tools.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "bag_recorder = impurity_common.bag_recorder_node:main",
        "bag_replay = impurity_common.bag_replay_node:main",
        "calibrate_camera = impurity_common.calibrate_camera:main",
        "cell_state_publisher = impurity_common.cell_state_publisher:main",
        "decision_markers = impurity_common.decision_markers:main",
    ]},
)
