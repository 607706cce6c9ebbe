from setuptools import find_packages, setup

package_name = "ur5_driver_rtde"

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
    description="ExecutePrimitive on a real UR5 (ur-rtde) with a Robotiq 2F-85, and a dry-run mode.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "ur5_driver = ur5_driver_rtde.ur5_driver_node:main",
    ]},
)
