from setuptools import find_packages, setup

package_name = "impurity_viz"

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
    description="TF, robot model and decision markers for RViz / Foxglove.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "cell_state_publisher = impurity_viz.cell_state_publisher:main",
        "decision_markers = impurity_viz.decision_markers:main",
    ]},
)
