"""What a real cell deploys imports neither the simulator nor learning code, and every package's
package.xml names exactly the cell packages its modules import (impurity_bringup: and those whose nodes
it launches).

Runtime executables are imported in a fresh interpreter each (as `ros2 run` starts them), and the
modules they pulled in are checked; the package dependencies are read from the source with `ast`.
"""

import json
import pathlib
import subprocess
import sys
import xml.etree.ElementTree as ElementTree

import pytest
from source_scan import imported_top_levels

ROOT = pathlib.Path(__file__).resolve().parents[2]
SRC = ROOT / "src"
BRINGUP = ROOT / "bringup"  # impurity_bringup's package directory
# (package, module) of every executable a real cell runs: perception, policy, episodes, bag tools, the
# arm driver, the camera calibration tool and what RViz / Foxglove show.
RUNTIME_EXECUTABLES = [
    ("impurity_attention", "impurity_attention.heightmap_node"),
    ("impurity_attention", "impurity_attention.attention_node"),
    ("impurity_policy", "impurity_policy.policy_node"),
    ("impurity_policy", "impurity_policy.episode_node"),
    ("impurity_bags", "impurity_bags.bag_recorder_node"),
    ("impurity_bags", "impurity_bags.bag_replay_node"),
    ("ur5_driver_rtde", "ur5_driver_rtde.ur5_driver_node"),
    ("impurity_calibration", "impurity_calibration.calibrate_camera"),
    ("impurity_viz", "impurity_viz.cell_state_publisher"),
    ("impurity_viz", "impurity_viz.decision_markers"),
    ("impurity_bringup", "impurity_bringup.launch_cell"),
    ("impurity_bringup", "impurity_bringup.episode_client"),
]
# Executables that never run the network, so never load torch.
NO_NETWORK_EXECUTABLES = ("impurity_policy.episode_node", "impurity_bags.bag_recorder_node",
                          "impurity_bags.bag_replay_node", "impurity_attention.heightmap_node",
                          "impurity_attention.attention_node", "ur5_driver_rtde.ur5_driver_node",
                          "impurity_calibration.calibrate_camera", "impurity_viz.cell_state_publisher",
                          "impurity_viz.decision_markers", "impurity_bringup.launch_cell",
                          "impurity_bringup.episode_client")
# Never on a real cell: the simulator, its physics engine, training and evaluation, and the cluster
# runtime they may run on (ray).
FORBIDDEN = ("pybullet", "ur5_driver_sim", "impurity_learning", "ray")
CELL_PACKAGES = sorted(p.name for p in SRC.iterdir() if (p / "package.xml").is_file())
RUNTIME_PACKAGES = ("impurity_common", "impurity_bags", "impurity_calibration", "impurity_viz", "ur5_motion",
                    "impurity_attention", "impurity_policy", "ur5_driver_rtde")
# Dependencies on a package's installed files rather than its modules.
DATA_DEPENDENCIES = {"impurity_bags": {"impurity_interfaces"}}  # bags.py reads its .msg files
# package.xml's condition on impurity_bringup's dependencies that only the simulated cell needs.
SIMULATED_CELL_ONLY = "$IMPURITY_CELL != real"


def imported_modules(module: str) -> list[str]:
    code = (f"import importlib, json, sys; importlib.import_module({module!r}); "
            "print(json.dumps(sorted(sys.modules)))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, f"importing {module} failed:\n{done.stderr[-2000:]}"
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("package,module", RUNTIME_EXECUTABLES, ids=[m for _, m in RUNTIME_EXECUTABLES])
def test_runtime_executable_imports_no_simulator_or_learning_code(package, module):
    loaded = imported_modules(module)
    offending = sorted(m for m in loaded if m.split(".")[0] in FORBIDDEN)
    assert not offending, f"{module} (deployed on a real cell) imports {offending}"
    if module in NO_NETWORK_EXECUTABLES:  # torch alone is ~200 MB of resident memory per process
        assert "torch" not in loaded, f"{module} does not run the network but imports torch"


def first_party_imports(package: str) -> set[str]:
    """Cell packages that the modules of `package` import (at any depth of the module)."""
    return (imported_top_levels(SRC / package / package) & set(CELL_PACKAGES)) - {package}


def declared_dependencies(package: str) -> set[str]:
    root = ElementTree.parse(SRC / package / "package.xml").getroot()
    tags = ("depend", "exec_depend", "build_depend")
    return {element.text.strip() for tag in tags for element in root.iter(tag)} & set(CELL_PACKAGES)


@pytest.mark.parametrize("package", [p for p in CELL_PACKAGES if p != "impurity_interfaces"])
def test_package_xml_names_the_cell_packages_its_modules_import(package):
    expected = first_party_imports(package) | DATA_DEPENDENCIES.get(package, set())
    assert declared_dependencies(package) == expected


@pytest.mark.parametrize("package", RUNTIME_PACKAGES)
def test_runtime_packages_depend_on_no_simulator_or_learning_package(package):
    assert not declared_dependencies(package) & set(FORBIDDEN), f"{package}/package.xml"


# ------------------------------------------------------------------------------------ impurity_bringup
def bringup_dependencies() -> dict[str, str | None]:
    """Cell package -> its `condition` attribute (None: unconditional) of impurity_bringup's package.xml."""
    root = ElementTree.parse(BRINGUP / "package.xml").getroot()
    return {element.text.strip(): element.get("condition") for tag in ("depend", "exec_depend")
            for element in root.iter(tag) if element.text.strip() in CELL_PACKAGES}


def test_impurity_bringup_depends_on_what_it_imports_and_the_packages_whose_nodes_it_launches():
    from impurity_bringup.cell_nodes import CELLS

    launched = {package for nodes in CELLS.values() for package, _ in nodes}
    imported = imported_top_levels(BRINGUP / "impurity_bringup") & set(CELL_PACKAGES)
    assert set(bringup_dependencies()) == imported | launched


def test_impurity_bringup_on_a_real_cell_depends_on_no_simulator_or_learning_package():
    on_a_real_cell = {package for package, condition in bringup_dependencies().items()
                      if condition != SIMULATED_CELL_ONLY}
    assert not on_a_real_cell & set(FORBIDDEN)
    assert {p for p, c in bringup_dependencies().items() if c == SIMULATED_CELL_ONLY} <= set(FORBIDDEN)


def test_the_launch_file_imports_no_simulator_or_learning_code():
    assert not imported_top_levels(BRINGUP / "launch") & set(FORBIDDEN)


# ------------------------------------------------------------------------ the runtime's tests on CPython 3.12
# A CPython 3.12 venv sets up the runtime alone: no PyBullet (requirements.txt). The runtime's unit tests
# that name the simulator must pass there, but for their cases marked `simulator` (tests/conftest.py skips
# those on 3.12).
BLOCK_PYBULLET = ("import sys\n"
                  "for name in ('pybullet', 'pybullet_data', 'pybullet_utils'):\n"
                  "    sys.modules[name] = None  # import raises ModuleNotFoundError\n"
                  "import pytest\n"
                  "sys.exit(pytest.main(sys.argv[1:]))\n")


def runtime_tests_naming_the_simulator() -> list[str]:
    return sorted(str(path.relative_to(ROOT)) for package in RUNTIME_PACKAGES
                  for path in (ROOT / "tests" / "unit" / package).glob("test_*.py")
                  if any(word in path.read_text() for word in ("ur5_driver_sim", "pybullet", "CellWorld")))


def test_the_runtimes_unit_tests_pass_without_pybullet_but_for_the_simulators_cases():
    files = runtime_tests_naming_the_simulator()
    assert "tests/unit/ur5_driver_rtde/test_dry_run.py" in files
    run = subprocess.run([sys.executable, "-c", BLOCK_PYBULLET, "-q", "-n", "0", "-p", "no:cacheprovider",
                          "-m", "not simulator", *files],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, f"without PyBullet:\n{run.stdout[-4000:]}{run.stderr[-2000:]}"
