"""Reading a weights file: each way it can be unusable gives the caller's error naming the file and why."""

import pytest
import torch

from impurity_common.weights_file import check_tensors, read_versioned


class Refused(RuntimeError):
    pass


def read(path):
    return read_versioned(path, "test network", 3, Refused)


def test_a_file_of_this_version_is_read_as_saved(tmp_path):
    torch.save({"format_version": 3, "weights": {"w": torch.ones(2)}}, tmp_path / "ok.pt")
    data = read(tmp_path / "ok.pt")
    assert data["format_version"] == 3 and torch.equal(data["weights"]["w"], torch.ones(2))


def test_each_unusable_file_is_refused_with_the_file_and_the_reason(tmp_path):
    with pytest.raises(Refused, match=r"test network .*missing\.pt does not exist"):
        read(tmp_path / "missing.pt")
    (tmp_path / "garbage.pt").write_bytes(b"not a torch file")
    with pytest.raises(Refused, match="garbage.pt cannot be read"):
        read(tmp_path / "garbage.pt")
    torch.save({"weights": {}}, tmp_path / "bare.pt")
    with pytest.raises(Refused, match=r"has no format_version \(not a test network file\)"):
        read(tmp_path / "bare.pt")
    torch.save({"format_version": 4}, tmp_path / "v4.pt")
    with pytest.raises(Refused, match="has format version 4, this code reads version 3"):
        read(tmp_path / "v4.pt")


def test_tensors_must_be_exactly_the_networks_with_its_shapes():
    reference = {"a": torch.zeros(2, 3), "b": torch.zeros(4)}
    check_tensors({"a": torch.ones(2, 3), "b": torch.ones(4)}, reference, "f.pt", "Net", Refused)
    with pytest.raises(Refused, match=r"f.pt does not match Net: missing \['b'\], unexpected \['c'\]"):
        check_tensors({"a": torch.ones(2, 3), "c": torch.ones(4)}, reference, "f.pt", "Net", Refused)
    with pytest.raises(Refused, match=r"f.pt: tensor 'a' has shape \(3, 2\), Net needs \(2, 3\)"):
        check_tensors({"a": torch.ones(3, 2), "b": torch.ones(4)}, reference, "f.pt", "Net", Refused)
