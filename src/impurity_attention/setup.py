import glob

from setuptools import find_packages, setup

package_name = "impurity_attention"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/checkpoints",
         sorted(glob.glob("checkpoints/*.pt") + glob.glob("checkpoints/*.json"))),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Impurity cell team",
    maintainer_email="robotics@impurity-cell.dev",
    description="RGB-D to heightmaps and the attention module (VOCUS2 saliency, DBSCAN).",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "heightmap_node = impurity_attention.heightmap_node:main",
        "attention_node = impurity_attention.attention_node:main",
    ]},
)
