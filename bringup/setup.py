from glob import glob

from setuptools import find_packages, setup

package_name = "impurity_bringup"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/launch", sorted(glob("launch/*.launch.py"))),
        ("share/" + package_name + "/config",
         sorted(glob("config/*.yaml") + glob("config/*.rviz") + glob("config/*.foxglove.json"))),
        ("share/" + package_name + "/config/sros2", sorted(glob("config/sros2/*.xml"))),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Impurity cell team",
    maintainer_email="robotics@impurity-cell.dev",
    description="Bringup: launch file, parameter files, launch_cell, episode_client, demo, eval_graph.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "launch_cell = impurity_bringup.launch_cell:main",
        "episode_client = impurity_bringup.episode_client:main",
        "demo = impurity_bringup.demo:main",
        "eval_graph = impurity_bringup.eval_graph:main",
    ]},
)
