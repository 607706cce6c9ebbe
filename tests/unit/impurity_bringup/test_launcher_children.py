"""launch_cell's node processes (impurity_bringup.launch_cell.CellProcesses) end with the launcher: one killed
outright (SIGKILL, no chance to stop them) leaves no node running on the domain."""

import os
import signal
import subprocess
import sys
import time

import pytest

LAUNCHER = """
import sys
from impurity_bringup.launch_cell import CellProcesses
cell = CellProcesses([("sleeper", [sys.executable, "-c", "import time; time.sleep(120)"])], None, quiet=True)
print(cell.processes[0][1].pid, flush=True)
import time; time.sleep(120)
"""


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as stat:  # a zombie waiting for its reaper has ended
        return stat.read().split()[2] != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_a_launcher_killed_outright_takes_its_nodes_with_it():
    launcher = subprocess.Popen([sys.executable, "-c", LAUNCHER], stdout=subprocess.PIPE, text=True)
    child = int(launcher.stdout.readline())
    assert alive(child)
    launcher.send_signal(signal.SIGKILL)
    launcher.wait(timeout=30)
    deadline = time.monotonic() + 30.0
    while alive(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not alive(child), "the node outlived its launcher"
