from setuptools import find_packages, setup

package_name = "impurity_bags"

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
    description="Episode bags: recorder and replay nodes and their core.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "bag_recorder = impurity_bags.bag_recorder_node:main",
        "bag_replay = impurity_bags.bag_replay_node:main",
    ]},
)
