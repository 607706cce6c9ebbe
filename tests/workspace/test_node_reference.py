"""scripts/node_reference.py prints the node reference from the nodes' parameter dataclasses and source, and
its --check mode tells a current generated block from a stale one (on files of the test's own)."""

import importlib.util
import pathlib
import subprocess
import sys

import pytest

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "scripts" / "node_reference.py"
spec = importlib.util.spec_from_file_location("node_reference", SCRIPT)
node_reference = importlib.util.module_from_spec(spec)
spec.loader.exec_module(node_reference)


@pytest.fixture(scope="module")
def printed() -> str:
    done = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_the_reference_has_every_executable_between_the_markers(printed):
    assert printed.strip().startswith(node_reference.BEGIN) and printed.strip().endswith(node_reference.END)
    for executable, (package, _, _) in node_reference.NODES.items():
        assert f"#### `{executable}` ({package})" in printed


def test_every_parameter_of_every_table_entry_is_listed(printed):
    from impurity_common.parameters import parameter_specs

    for _, target, _ in node_reference.NODES.values():
        for parameter in parameter_specs(node_reference.parameters_class(target)):
            assert f"| `{parameter.name}` |" in printed


def test_topics_services_and_actions_are_read_from_the_node_modules(printed):
    from impurity_common import names

    attention = printed[printed.index("#### `attention_node`"):printed.index("#### `policy_node`")]
    assert f"publishes `{names.ATTENTION_TOPIC}`" in attention
    assert f"`{names.HEIGHTMAP_TOPIC}`" in attention and f"serves `{names.LOOK_CLOSER_SERVICE}`" in attention
    episode = printed[printed.index("#### `episode_node`"):printed.index("#### `cell_state_publisher`")]
    assert f"action server `{names.RUN_EPISODE_ACTION}`" in episode
    assert f"action client `{names.EXECUTE_PRIMITIVE_ACTION}`" in episode


def test_check_passes_on_a_current_block_and_fails_on_a_stale_or_missing_one(tmp_path):
    current = tmp_path / "current.md"
    current.write_text("# A page\n\n" + node_reference.reference() + "\n\nAfter.\n")
    assert node_reference.main(["--check", str(current)]) == 0
    stale = tmp_path / "stale.md"
    stale.write_text(f"# A page\n\n{node_reference.BEGIN}\nold\n{node_reference.END}\n")
    assert node_reference.main(["--check", str(stale)]) == 1
    missing = tmp_path / "missing.md"
    missing.write_text("# A page without the block\n")
    assert node_reference.main(["--check", str(missing)]) == 1


def test_write_replaces_only_the_block(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(f"Before.\n{node_reference.BEGIN}\nold\n{node_reference.END}\nAfter.\n")
    assert node_reference.main(["--write", str(page)]) == 0
    text = page.read_text()
    assert text.startswith("Before.\n") and text.endswith("\nAfter.\n")
    assert node_reference.main(["--check", str(page)]) == 0
