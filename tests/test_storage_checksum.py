"""The measurement's checksum: unchanged by stored results, changed by one sample."""

import h5py
import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.storage import write_processed
from labjoint.storage.checksum import raw_sha256
from test_storage_fixtures import write_run


def test_results_leave_it_alone_and_one_sample_changes_it(tmp_path):
    volts = np.random.default_rng(0).standard_normal((4, 3000))
    path = write_run(tmp_path, "a", volts)
    before = raw_sha256(path)
    write_processed(path, "loop", {"damping": np.arange(5.0)}, {"damping": "N*s/m"})
    write_processed(path, "loop", {"damping": np.arange(6.0)}, {"damping": "N*s/m"})
    assert raw_sha256(path) == before                    # results are not the measurement
    with h5py.File(path, "r+") as f:
        ds = next(d for d in f["entry/data"].values()
                  if isinstance(d, h5py.Dataset) and d.ndim == 1 and d.size > 10 and d.name != "/entry/data/time")
        ds[3] = ds[3] + 1e-9
    assert raw_sha256(path) != before


def test_a_missing_or_foreign_file_is_named(tmp_path):
    with pytest.raises(InputError, match="disappeared"):
        raw_sha256(tmp_path / "gone.h5")
    (tmp_path / "x.h5").write_bytes(b"not hdf5")
    with pytest.raises(InputError, match="x.h5"):
        raw_sha256(tmp_path / "x.h5")
