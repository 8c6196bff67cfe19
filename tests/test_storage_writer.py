"""RunWriter: documents -> NeXus run file -> Run, gaps, markers, flush clock, lifecycle."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from labjoint.documents import Block, Marker, RunStart, RunStop
from labjoint.errors import InputError
from labjoint.storage import open_run, read_run
from labjoint.storage.writer import RunWriter
from test_storage_fixtures import FS, LSB, NC_CAL, quantise, rig_channels, walk_nexus, write_run


def _sine_volts(n: int, f: float = 400.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Volts of a joint slipping 10 um against 60 N (true displacement and force too)."""
    t = np.arange(n) / FS
    u1 = 6e-6 * np.sin(2 * np.pi * f * t)
    u2 = -4e-6 * np.sin(2 * np.pi * f * t)
    force = 60.0 * np.sin(2 * np.pi * f * t + 0.3)
    volts = np.vstack([force / 50.0, u1 / 1.25e-5, u2 / 1.25e-5, force / 301.0])
    return quantise(volts), u1 - u2, force


def test_round_trip_gives_physical_units_within_quantisation(tmp_path):
    volts, disp, force = _sine_volts(12_345)
    path = write_run(tmp_path, "rt", volts, block=1000)
    run = read_run(path)
    assert run.name == "rt" and len(run) == 12_345
    np.testing.assert_allclose(run.time, np.arange(12_345) / FS, rtol=0, atol=1e-15)
    # one LSB per channel at most, times the sensitivity: the quantisation of the DAQ
    assert np.max(np.abs(run.displacement - disp)) <= 1.25e-5 * LSB
    assert np.max(np.abs(run.force - force)) <= 301.0 * LSB / 2 + 1e-12
    ref = read_run(path, force="reference")
    assert np.max(np.abs(ref.force - force)) <= 50.0 * LSB / 2 + 1e-12
    with open_run(path) as rf:  # raw volts are kept bit for bit
        for i, name in enumerate(rf.channel_names):
            assert np.array_equal(rf.volts(name), volts[i])
    assert run.metadata["torque_nm"] == 5.0 and run.sample_rate_hz == FS


def test_nanocomposite_calibration_is_interpolated_at_run_frequency(tmp_path):
    volts = np.ones((4, 100))
    for f_hz, expected in [(400.0, 301.0), (300.0, 290.5), (1000.0, 320.0)]:
        path = write_run(tmp_path, f"cal{int(f_hz)}", volts, metadata={"frequency_hz": f_hz})
        with open_run(path) as rf:
            assert rf.channel("shear_nc").calibration == NC_CAL
            np.testing.assert_allclose(rf.physical("shear_nc"), expected)
            np.testing.assert_allclose(rf.physical("force_ref"), 50.0)


def test_file_follows_nexus_layout(tmp_path):
    path = write_run(tmp_path, "nx", np.zeros((4, 2000)))
    assert walk_nexus(path) == []
    with h5py.File(path, "r") as f:
        e = f["entry"]
        assert e.attrs["NX_class"] == "NXentry"
        assert e["data"].attrs["signal"] == "shear_nc" and e["data"].attrs["axes"] == "time"
        assert {e["instrument"][c].attrs["NX_class"] for c in ("force_ref", "shear_nc")} == {"NXsensor"}
        assert e["data/disp_1"].attrs["units"] == "V" and e["data/time"].attrs["units"] == "s"
        assert e["instrument/disp_1/sensitivity"].attrs["units"] == "m/V"
        assert e["sample/bolt_torque"][()] == 5.0 and e["sample/bolt_torque"].attrs["units"] == "N*m"
        assert e.attrs["excitation_vpp"] == 5.0
        assert e["status"][()] == b"complete" and e["n_samples"][()] == 2000


def test_metadata_generator_settings_and_extra_keys_are_kept(tmp_path):
    gen = {"frequency_hz": 400.0, "amplitude_vpp": 5.0, "offset_v": 0.0, "output": True,
           "idn": "TEKTRONIX,AFG1022"}
    md = {"generator": gen, "offset_v": 0.0, "operator": "ms", "bolt": {"size": "M8"},
          "software_version": "9.9"}
    path = write_run(tmp_path, "md", np.zeros((4, 10)), metadata=md)
    with open_run(path) as rf:
        m = rf.metadata
        assert m["generator"] == gen and m["operator"] == "ms" and m["bolt"] == {"size": "M8"}
        assert m["software_version"] == "9.9" and m["plan"] == "amplitude_sweep"
        assert m["status"] == "complete" and m["end_time"] and m["start_time"]
    with h5py.File(path, "r") as f:
        g = f["entry/instrument/generator"]
        assert g["frequency_hz"][()] == 400.0 and g["frequency_hz"].attrs["units"] == "Hz"
        assert g["idn"][()] == b"TEKTRONIX,AFG1022"


def test_gap_in_sample_counter_is_recorded_and_shows_in_time(tmp_path):
    w = RunWriter(tmp_path)
    w("start", RunStart("g", "gap", rig_channels(), FS, {}))
    v = np.ones((4, 100))
    w("block", Block("g", 0, v))
    w("block", Block("g", 100, v))
    w("block", Block("g", 350, v))  # 150 samples lost
    w("block", Block("g", 450, v))
    w("stop", RunStop("g", "complete"))
    with open_run(tmp_path / "gap.h5") as rf:
        assert rf.gaps == [(200, 350)]
        assert rf.metadata["continuous"] is False and rf.n_samples == 400
        t = rf.time()
        assert np.isclose(t[200] - t[199], 151 / FS) and np.allclose(np.diff(t[:200]), 1 / FS)


def test_repeated_samples_are_dropped_not_duplicated(tmp_path):
    w = RunWriter(tmp_path)
    w("start", RunStart("o", "overlap", rig_channels(), FS, {}))
    full = np.arange(400.0)[None, :] * np.ones((4, 1))
    w("block", Block("o", 0, full[:, :200]))
    w("block", Block("o", 150, full[:, 150:300]))  # counter stepped back 50
    w("block", Block("o", 300, full[:, 300:]))
    w("stop", RunStop("o", "complete"))
    with open_run(tmp_path / "overlap.h5") as rf:
        assert rf.gaps == [(200, 150)]
        assert np.array_equal(rf.volts("disp_1"), np.arange(400.0))
        assert np.all(np.diff(rf.time()) > 0)


def test_continuous_run_has_no_gaps(tmp_path):
    path = write_run(tmp_path, "cont", np.zeros((4, 30_000)), block=4096)
    with open_run(path) as rf:
        assert rf.gaps == [] and rf.metadata["continuous"] is True


def test_markers_and_stop_metadata_are_stored(tmp_path):
    w = RunWriter(tmp_path)
    w("start", RunStart("m", "mk", rig_channels(), FS, {}))
    w("block", Block("m", 0, np.zeros((4, 1000))))
    w("marker", Marker("m", "steady", 600, {"cycles": 12}))
    w("marker", Marker("m", "big", 700, {"note": "x" * 5000}))  # longer than one event row
    w("stop", RunStop("m", "limit", reason="displacement 210 um > 200 um",
                      metadata={"max_displacement_m": 2.1e-4}))
    with open_run(tmp_path / "mk.h5") as rf:
        assert rf.status == "limit"
        assert rf.metadata["reason"] == "displacement 210 um > 200 um"
        assert rf.metadata["max_displacement_m"] == 2.1e-4
        marks = rf.metadata["markers"]
        assert marks[0] == {"name": "steady", "sample": 600, "data": {"cycles": 12}}
        assert marks[1]["data"]["note"] == "x" * 5000


def test_status_is_running_until_stop(tmp_path):
    w = RunWriter(tmp_path)
    w("start", RunStart("s", "life", rig_channels(), FS, {}))
    w("block", Block("s", 0, np.zeros((4, 10))))
    w.flush()
    with open_run(tmp_path / "life.h5") as rf:
        assert rf.status == "running" and rf.n_samples == 10
    w("stop", RunStop("s", "aborted", reason="user"))
    with open_run(tmp_path / "life.h5") as rf:
        assert rf.status == "aborted"


def test_writer_close_marks_unstopped_runs_incomplete(tmp_path):
    with RunWriter(tmp_path) as w:
        w("start", RunStart("c", "closed", rig_channels(), FS, {}))
        w("block", Block("c", 0, np.zeros((4, 10))))
    with open_run(tmp_path / "closed.h5") as rf:
        assert rf.status == "incomplete" and rf.n_samples == 10


def test_flush_happens_on_the_clock_not_every_block(tmp_path, monkeypatch):
    now = [0.0]
    flushes = []
    real_flush = h5py.File.flush
    monkeypatch.setattr(h5py.File, "flush", lambda self: (flushes.append(now[0]), real_flush(self)))
    w = RunWriter(tmp_path, flush_interval_s=1.0, clock=lambda: now[0])
    w("start", RunStart("f", "flush", rig_channels(), FS, {}))
    flushes.clear()
    for k in range(25):  # a block every 0.1 s for 2.5 s
        now[0] = 0.1 * (k + 1)
        w("block", Block("f", 100 * k, np.zeros((4, 100))))
    assert len(flushes) == 2 and all(b - a >= 1.0 for a, b in zip([0.0] + flushes, flushes))
    now[0] = 3.6
    w.flush_if_due()
    assert len(flushes) == 3
    w("stop", RunStop("f", "complete"))


def test_half_created_file_never_has_the_run_name(tmp_path, monkeypatch):
    from labjoint.storage import layout

    def broken(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(layout, "create_layout", broken)
    with pytest.raises(RuntimeError):
        RunWriter(tmp_path)("start", RunStart("b", "broken", rig_channels(), FS, {}))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("doc_name, doc, field", [
    ("block", Block("nope", 0, np.zeros((4, 3))), "uid"),
    ("stop", RunStop("nope", "complete"), "uid"),
    ("start", RunStart("x", "bad/name", rig_channels(), FS, {}), "name"),
    ("start", RunStart("x", "ok", rig_channels()[:1] * 2, FS, {}), "channels"),
    ("start", RunStart("x", "ok", rig_channels(), 0.0, {}), "sample_rate_hz"),
    ("frob", Block("x", 0, np.zeros((4, 3))), "document"),
])
def test_bad_documents_raise_input_error(tmp_path, doc_name, doc, field):
    with pytest.raises(InputError) as ei:
        RunWriter(tmp_path)(doc_name, doc)
    assert ei.value.field == field
    assert not list(tmp_path.glob("*.h5")) and not list(tmp_path.glob(".*"))


def test_block_shape_and_final_status_are_checked(tmp_path):
    w = RunWriter(tmp_path)
    w("start", RunStart("k", "chk", rig_channels(), FS, {}))
    with pytest.raises(InputError, match="shape"):
        w("block", Block("k", 0, np.zeros((3, 10))))
    with pytest.raises(InputError, match="final status"):
        w("stop", RunStop("k", "running"))
    w("stop", RunStop("k", "failed", reason="DAQ error"))


def test_existing_run_is_never_overwritten(tmp_path):
    path = write_run(tmp_path, "dup", np.ones((4, 50)))
    before = path.read_bytes()
    with pytest.raises(InputError, match="already exists") as ei:
        write_run(tmp_path, "dup", np.zeros((4, 50)), uid="other")
    assert ei.value.file == str(path) and path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["dup.h5"]
