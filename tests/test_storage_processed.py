"""Processed results live in /entry/processed and never touch raw data."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from labjoint.documents import RunStart, RunStop
from labjoint.errors import InputError
from labjoint.storage import open_run, read_processed, write_processed
from labjoint.storage.writer import RunWriter
from test_storage_fixtures import FS, rig_channels, walk_nexus, write_run


def _raw_snapshot(path):
    """Every dataset and attribute outside /entry/processed."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if name.startswith("entry/processed"):
                return
            out[name + "@"] = {k: np.asarray(v).tolist() for k, v in obj.attrs.items()}
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[()].tobytes() if obj.dtype.kind != "O" else obj[()]
        f.visititems(visit)
    return out


@pytest.fixture
def path(tmp_path):
    rng = np.random.default_rng(1)
    return write_run(tmp_path, "p", rng.normal(size=(4, 3000)))


def test_processed_results_round_trip_and_raw_is_untouched(path):
    before = _raw_snapshot(path)
    loops = {"energy_loss_j": np.array([1.2e-4, 1.3e-4]), "stiffness_n_per_m": np.array([2e7, 2.1e7])}
    write_processed(path, "hysteresis", {**loops, "cycles": np.arange(2), "per_cycle": {"area": np.ones(3)}},
                    attrs={"method": "seed 002 Eq. 1", "n_cycles": 2, "settings": {"cutoff_hz": 3000}},
                    units={"energy_loss_j": "J", "stiffness_n_per_m": "N/m", "per_cycle": {"area": "J"}})
    arrays, attrs = read_processed(path, "hysteresis")
    assert np.array_equal(arrays["energy_loss_j"], loops["energy_loss_j"])
    assert np.array_equal(arrays["per_cycle"]["area"], np.ones(3))
    assert attrs["method"] == "seed 002 Eq. 1" and attrs["n_cycles"] == 2
    assert attrs["settings"] == '{"cutoff_hz": 3000}'
    with h5py.File(path, "r") as f:
        g = f["entry/processed/hysteresis"]
        assert g.attrs["NX_class"] == "NXprocess"
        assert g["energy_loss_j"].attrs["units"] == "J" and g["per_cycle/area"].attrs["units"] == "J"
        assert g["cycles"].attrs["units"] == ""
    assert _raw_snapshot(path) == before
    assert walk_nexus(path) == []


def test_same_name_replaces_the_earlier_result_only(path):
    write_processed(path, "fit", {"k": np.array([1.0, 2.0])}, units={"k": "N/m"})
    write_processed(path, "other", {"x": np.array([5.0])})
    before = _raw_snapshot(path)
    write_processed(path, "fit", {"c": np.array([3.0])}, units={"c": "N*s/m"})
    arrays, _ = read_processed(path, "fit")
    assert set(arrays) == {"c", "program", "version", "date"}
    assert read_processed(path, "other")[0]["x"].tolist() == [5.0]
    with open_run(path) as rf:
        assert rf.processed_names == ["fit", "other"]
    assert _raw_snapshot(path) == before


@pytest.mark.parametrize("group", ["../data", "data/x", "", ".hidden", "a b", "9lives"])
def test_group_names_that_could_escape_are_refused(path, group):
    before = _raw_snapshot(path)
    with pytest.raises(InputError, match="group name"):
        write_processed(path, group, {"x": np.ones(2)})
    assert _raw_snapshot(path) == before


def test_bad_arrays_leave_no_partial_group(path):
    with pytest.raises(InputError, match="numeric"):
        write_processed(path, "bad", {"ok": np.ones(2), "obj": np.array([object()])})
    with pytest.raises(InputError, match="reserved"):
        write_processed(path, "bad", {"date": np.ones(2)})
    with open_run(path) as rf:
        assert rf.processed_names == []
    with h5py.File(path, "r") as f:
        assert list(f["entry/processed"]) == []


def test_a_run_being_written_is_refused(tmp_path):
    w = RunWriter(tmp_path)
    w("start", RunStart("u", "busy", rig_channels(), FS, {}))
    with pytest.raises(InputError, match="being written"):
        write_processed(tmp_path / "busy.h5", "x", {"a": np.ones(1)})
    w("stop", RunStop("u", "complete"))
    write_processed(tmp_path / "busy.h5", "x", {"a": np.ones(1)})


def test_missing_group_and_file_are_named(path, tmp_path):
    with pytest.raises(InputError, match="no processed group"):
        read_processed(path, "nothing")
    with pytest.raises(InputError, match="no such run file"):
        write_processed(tmp_path / "nope.h5", "x", {"a": np.ones(1)})


def test_unstorable_attribute_is_named(path):
    with pytest.raises(InputError) as ei:
        write_processed(path, "bad", {"x": np.ones(1)}, attrs={"mixed": [1, "a", {"b": 2}]})
    assert ei.value.field == "bad.attrs.mixed"
    with open_run(path) as rf:
        assert rf.processed_names == []
