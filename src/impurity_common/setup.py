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
    description="Cell geometry, names, enums, message conversions, the node main idiom, parameters.",
    license="Apache-2.0",
)
