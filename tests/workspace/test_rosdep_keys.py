"""Every package.xml declares, as rosdep keys, what the package's Python code imports, so that
`rosdep install --from-paths src bringup` installs it; and declares no Python key that nothing imports.

The imports are read from the source with `ast` (top-level module names, at any depth of a module):
- a package's modules (setup.py aside) need an `<exec_depend>` (or `<depend>`);
- its setup.py needs a `<buildtool_depend>` (or `<build_depend>`, `<depend>`);
- its unit tests (tests/unit/<package>) need a `<test_depend>` for what its modules do not import already.
Cell packages imported by unit tests are not declared: the tests run from the repository, not from an
installed package, and impurity_common's tests import ur5_driver_sim, which depends on impurity_common.
The standard library (sys.stdlib_module_names) needs no key.
"""

import pathlib
import sys
import xml.etree.ElementTree as ElementTree

import pytest
from source_scan import imported_top_levels

ROOT = pathlib.Path(__file__).resolve().parents[2]
TESTS = ROOT / "tests"
PACKAGE_DIRS = {path.parent.name: path.parent for path in (ROOT / "src").glob("*/package.xml")}
PACKAGE_DIRS["impurity_bringup"] = ROOT / "bringup"
CELL_PACKAGES = set(PACKAGE_DIRS)
PYTHON_PACKAGES = sorted(name for name, path in PACKAGE_DIRS.items() if (path / "setup.py").is_file())
# What a real cell deploys.
RUNTIME_PACKAGES = ("impurity_common", "impurity_attention", "impurity_policy", "impurity_bags",
                    "impurity_calibration", "impurity_viz", "ur5_motion", "ur5_driver_rtde",
                    "impurity_interfaces", "impurity_bringup")

# Imported module (top level) -> the rosdep key that provides it: a ROS package's own name, a key of
# ros/rosdistro's rosdep/python.yaml, or None where no key exists (the package.xml says so in a comment).
ROSDEP_KEYS = {
    # ROS 2 packages
    "rclpy": "rclpy",
    "ament_index_python": "ament_index_python",
    "launch": "launch",
    "launch_ros": "launch_ros",
    "builtin_interfaces": "builtin_interfaces",
    "rcl_interfaces": "rcl_interfaces",
    "unique_identifier_msgs": "unique_identifier_msgs",
    "std_msgs": "std_msgs",
    "std_srvs": "std_srvs",
    "geometry_msgs": "geometry_msgs",
    "sensor_msgs": "sensor_msgs",
    "visualization_msgs": "visualization_msgs",
    "tf2_msgs": "tf2_msgs",
    "rosgraph_msgs": "rosgraph_msgs",
    "diagnostic_msgs": "diagnostic_msgs",
    "lifecycle_msgs": "lifecycle_msgs",
    # Python packages (rosdep/python.yaml)
    "numpy": "python3-numpy",
    "scipy": "python3-scipy",
    "cv2": "python3-opencv",
    "sklearn": "python3-sklearn",
    "torch": "python3-torch",
    "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib",
    "tqdm": "python3-tqdm",
    "pybullet": "python3-pybullet-pip",
    "pybullet_utils": "python3-pybullet-pip",  # part of the pybullet distribution
    "rosbags": "python3-rosbags-pip",
    "setuptools": "python3-setuptools",
    "pytest": "python3-pytest",
    # No rosdep key: pip installs them from requirements.txt.
    "ray": None,  # ray (the cluster runtime of impurity_learning's --ray)
    "rtde_control": None,  # ur-rtde
    "rtde_receive": None,  # ur-rtde
    "dashboard_client": None,  # ur-rtde
}
PYTHON_KEYS = {key for module, key in ROSDEP_KEYS.items() if key and key != module}
# Keys that only the simulator, training and evaluation need.
SIMULATION_AND_TRAINING_KEYS = {"python3-pybullet-pip", "python3-matplotlib", "python3-tqdm"}
# Test helper modules, imported by the tests from tests/ and its folders.
TEST_HELPERS = {path.stem for path in TESTS.rglob("*.py")}
STANDARD_LIBRARY = set(sys.stdlib_module_names)


def keys_of(modules: set[str], package: str, *, tests: bool = False) -> set[str]:
    """The rosdep keys of `modules` (imported by `package`'s code, or by its tests): cell packages by their
    name (left out for tests), the rest by ROSDEP_KEYS; the standard library and modules without a key
    give none."""
    keys = set()
    for module in modules - STANDARD_LIBRARY - {package}:
        if module in CELL_PACKAGES:
            keys |= set() if tests else {module}
        elif tests and module in TEST_HELPERS:
            continue
        else:
            assert module in ROSDEP_KEYS, f"{package} imports {module}: add it to ROSDEP_KEYS"
            keys |= {ROSDEP_KEYS[module]} - {None}
    return keys


def module_imports(package: str) -> set[str]:
    directory = PACKAGE_DIRS[package]
    sources = [path for path in directory.rglob("*.py") if path.name != "setup.py"]
    return set().union(*(imported_top_levels(path) for path in sources))


def needed_at_run_time(package: str) -> set[str]:
    return keys_of(module_imports(package), package)


def needed_to_build(package: str) -> set[str]:
    return keys_of(imported_top_levels(PACKAGE_DIRS[package] / "setup.py"), package)


def needed_by_tests_only(package: str) -> set[str]:
    unit_tests = TESTS / "unit" / package
    imported = imported_top_levels(unit_tests) if unit_tests.is_dir() else set()
    return keys_of(imported, package, tests=True) - needed_at_run_time(package)


def declared(package: str, *tags: str) -> set[str]:
    root = ElementTree.parse(PACKAGE_DIRS[package] / "package.xml").getroot()
    return {element.text.strip() for tag in tags for element in root.iter(tag)}


def declared_run_keys(package: str) -> set[str]:
    return declared(package, "depend", "exec_depend")


def declared_build_keys(package: str) -> set[str]:
    return declared(package, "depend", "build_depend", "buildtool_depend")


def declared_test_keys(package: str) -> set[str]:
    return declared(package, "test_depend")


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_package_xml_declares_what_its_modules_import_as_run_dependencies(package):
    assert needed_at_run_time(package) - declared_run_keys(package) == set()


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_package_xml_declares_what_its_setup_py_imports_as_build_dependencies(package):
    assert needed_to_build(package) - declared_build_keys(package) == set()


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_package_xml_declares_what_only_its_unit_tests_import_as_test_dependencies(package):
    assert needed_by_tests_only(package) - declared_test_keys(package) == set()


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_package_xml_declares_no_run_dependency_on_a_python_key_or_ros_package_its_modules_do_not_import(
        package):
    ros_packages_and_python_keys = {key for key in ROSDEP_KEYS.values() if key}
    assert (declared_run_keys(package) & ros_packages_and_python_keys) - needed_at_run_time(package) == set()


@pytest.mark.parametrize("package", sorted(CELL_PACKAGES))
def test_package_xml_declares_no_python_build_or_test_key_that_nothing_needs(package):
    assert (declared_build_keys(package) & PYTHON_KEYS) - needed_to_build(package) == set()
    assert (declared_test_keys(package) & PYTHON_KEYS) - needed_by_tests_only(package) == set()


@pytest.mark.parametrize("package", RUNTIME_PACKAGES)
def test_runtime_packages_declare_no_simulator_or_training_key(package):
    assert not declared(package, "depend", "exec_depend", "build_depend", "test_depend") \
        & SIMULATION_AND_TRAINING_KEYS


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_package_xml_says_which_imported_modules_have_no_rosdep_key(package):
    root = ElementTree.parse(PACKAGE_DIRS[package] / "package.xml", ElementTree.XMLParser(
        target=ElementTree.TreeBuilder(insert_comments=True))).getroot()
    comments = " ".join(node.text for node in root.iter() if node.tag is ElementTree.Comment)
    without_key = {module for module in module_imports(package) if module in ROSDEP_KEYS
                   and ROSDEP_KEYS[module] is None}
    assert {module for module in without_key if module not in comments} == set()
    assert not without_key or "no rosdep key" in comments
