from setuptools import find_packages, setup

package_name = "ur5_driver_sim"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    # the named palettes (appearance.load_palettes reads them beside the module)
    package_data={package_name: ["data/*.yaml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Impurity cell team",
    maintainer_email="robotics@impurity-cell.dev",
    description="PyBullet UR5 + gripper cell: scenes, primitives, camera, driver node.",
    license="Apache-2.0",
    entry_points={"console_scripts": ["sim_cell = ur5_driver_sim.sim_cell:main"]},
)
