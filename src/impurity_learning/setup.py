import glob

from setuptools import find_packages, setup

package_name = "impurity_learning"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        # the baselines' and ablations' trained networks (the evaluation compares ours with them)
        ("share/" + package_name + "/checkpoints", glob.glob("checkpoints/*.pt")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Impurity cell team",
    maintainer_email="robotics@impurity-cell.dev",
    description="Training, TCDD rewards, replay, baselines and the paper's evaluation (fast sim).",
    license="Apache-2.0",
)
