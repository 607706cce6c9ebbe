"""The calibration tool on scenes the simulator renders: network, verifier and colour-reference in order
into one directory, on one tuning palette's first 12 scenes (a quick check of the command family, ~30 s), and
what they write is what the cell reads."""

import pytest

pytest.importorskip("ur5_driver_sim.core.world")

from impurity_attention.core.attention import attend  # noqa: E402
from impurity_attention.core.impurity_net import read_network  # noqa: E402
from impurity_attention.core.verifier import read_verifier  # noqa: E402
from impurity_learning.calibrate import attention_fit  # noqa: E402
from impurity_learning.calibrate.__main__ import main  # noqa: E402

SCENES = ["--palettes", "coal_slate", "--limit", "12", "--no-progress"]


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    out = tmp_path_factory.mktemp("calibration")
    assert main(["network", "--out", str(out), "--epochs", "1", *SCENES]) == 0
    assert main(["verifier", "--out", str(out), *SCENES]) == 0
    assert main(["colour-reference", "--out", str(out), *SCENES]) == 0
    return out


def test_the_commands_write_the_network_and_the_verifier_with_its_thresholds_beside_each_other(calibrated):
    assert read_network(calibrated / "impurity_net.pt") is not None
    verifier = read_verifier(calibrated / "verifier.json")  # the shipped format: the cell reads it as is
    assert verifier.reads_network  # fitted with the network written beside it
    assert verifier.threshold >= verifier.last_look >= verifier.stall_look
    assert (calibrated / "scenes.npz").exists()  # the rendered scenes, cached for the next command
    assert (calibrated / "colour_reference.json").exists()


def test_attention_runs_with_what_the_directory_holds(calibrated):
    from impurity_attention.core import evaluation
    params = attention_fit.attention_params(calibrated)
    assert params.verifier == read_verifier(calibrated / "verifier.json")
    record = evaluation.load_records(calibrated / "scenes.npz")[0]
    output = attend(record.color, record.height, params)
    assert output.mode is not None


def test_a_held_out_palette_is_refused_before_anything_is_rendered(tmp_path, capsys):
    assert main(["verifier", "--out", str(tmp_path), "--palettes", "pla_flakes_pet", "--no-progress"]) == 2
    assert "held_out" in capsys.readouterr().err
    assert not (tmp_path / "scenes.npz").exists()
