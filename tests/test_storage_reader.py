"""Reader: slicing, chunked iteration, channel choice, clear errors for bad files."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.storage import open_run, read_run
from test_storage_fixtures import FS, write_run


@pytest.fixture
def run_path(tmp_path):
    n = 10_007
    idx = np.arange(n, dtype=float)
    volts = np.vstack([idx, 2 * idx, idx, 3 * idx]) * 1e-4
    return write_run(tmp_path, "r", volts, block=3000)


def test_slices_follow_python_semantics(run_path):
    with open_run(run_path) as rf:
        assert rf.n_samples == 10_007
        assert np.array_equal(rf.volts("disp_1", 10, 13), np.array([20.0, 22.0, 24.0]) * 1e-4)
        assert np.array_equal(rf.volts("disp_1", -2), np.array([20_010.0, 20_012.0]) * 1e-4)
        assert rf.volts("disp_1", 20_000).size == 0 and rf.volts("disp_1", 50, 10).size == 0
        np.testing.assert_allclose(rf.time(100, 101), [100 / FS])


@pytest.mark.parametrize("block, overlap", [(1000, 0), (4096, 100), (10_007, 0), (20_000, 5), (7, 3)])
def test_iter_blocks_covers_every_sample_with_overlap(run_path, block, overlap):
    with open_run(run_path) as rf:
        whole = rf.physical("disp_2")
        blocks = list(rf.iter_blocks(block, channels=["disp_2", "shear_nc"], overlap=overlap))
        assert blocks[0].start == 0 and blocks[-1].stop == rf.n_samples
        for a, b in zip(blocks, blocks[1:]):
            assert b.start == a.stop - overlap
        for blk in blocks:
            assert np.array_equal(blk.data["disp_2"], whole[blk.start:blk.stop])
            assert np.array_equal(blk.time, rf.time(blk.start, blk.stop))
            assert set(blk.data) == {"disp_2", "shear_nc"}
        raw = next(rf.iter_blocks(block, physical=False))
        assert np.array_equal(raw.data["force_ref"], rf.volts("force_ref", 0, raw.stop))


def test_iter_blocks_rejects_bad_settings(run_path):
    with open_run(run_path) as rf:
        for kw in ({"block_samples": 0}, {"block_samples": 10, "overlap": 10},
                   {"block_samples": 10, "channels": ["nope"]}):
            with pytest.raises(InputError):
                next(rf.iter_blocks(**kw))


def test_displacement_is_difference_of_the_two_sensors(run_path):
    run = read_run(run_path)
    with open_run(run_path) as rf:
        d1, d2 = rf.physical("disp_1"), rf.physical("disp_2")
        assert np.array_equal(run.displacement, d1 - d2)
        assert np.array_equal(run.force, rf.physical("shear_nc"))
        assert np.array_equal(read_run(run_path, force="reference").force, rf.physical("force_ref"))
    assert set(run.channels) == {"force_ref", "disp_1", "disp_2", "shear_nc"}


def test_channel_names_come_from_metadata(tmp_path):
    volts = np.vstack([np.full(5, 1.0), np.full(5, 2.0), np.full(5, 3.0), np.full(5, 4.0)])
    path = write_run(tmp_path, "m", volts, metadata={"displacement_channels": ["disp_2", "disp_1"],
                                                     "joint_force_channel": "force_ref"})
    run = read_run(path)
    np.testing.assert_allclose(run.displacement, (3.0 - 2.0) * 1.25e-5)
    np.testing.assert_allclose(run.force, 50.0)


def test_missing_channel_and_bad_force_choice_are_named(tmp_path, run_path):
    path = write_run(tmp_path, "x", np.zeros((4, 3)), metadata={"joint_force_channel": "nope"})
    with pytest.raises(InputError, match="nope") as ei:
        read_run(path)
    assert ei.value.file == str(path)
    with pytest.raises(InputError, match="joint"):
        read_run(run_path, force="both")
    with open_run(run_path) as rf, pytest.raises(InputError, match="shear_nc"):
        rf.volts("shear")


def test_bad_files_get_errors_naming_the_path(tmp_path):
    missing = tmp_path / "missing.h5"
    text = tmp_path / "text.h5"
    text.write_text("not hdf5")
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["x"] = 1
    for p, msg in [(missing, "no such"), (text, "not a readable HDF5"), (foreign, "not a labjoint")]:
        with pytest.raises(InputError, match=msg) as ei:
            open_run(p)
        assert ei.value.file == str(p)


def test_truncated_file_is_reported_not_crashing(tmp_path, run_path):
    cut = tmp_path / "cut.h5"
    cut.write_bytes(run_path.read_bytes()[:4000])
    with pytest.raises(InputError) as ei:
        read_run(cut)
    assert ei.value.file == str(cut)
