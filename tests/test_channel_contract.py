"""The channel contract: quantities and SI units of every channel, drive and response
roles, read_channels on new and older run files, and volts never used as newtons."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.storage import open_run, read_run
from labjoint.storage.quantities import SI_UNITS, parse_unit, to_si
from labjoint.storage.reader import read_channels
from test_storage_fixtures import write_run


@pytest.mark.parametrize("quantity, unit, factor", [
    ("displacement", "m", 1.0), ("displacement", "mm", 1e-3), ("displacement", "um", 1e-6),
    ("displacement", "\u00b5m", 1e-6), ("displacement", "\u03bcm", 1e-6), ("displacement", "nm", 1e-9),
    ("velocity", "m/s", 1.0), ("velocity", "mm/s", 1e-3), ("velocity", "um/s", 1e-6),
    ("acceleration", "m/s^2", 1.0), ("acceleration", "m/s\u00b2", 1.0), ("acceleration", "m/s2", 1.0),
    ("acceleration", "mm/s^2", 1e-3), ("acceleration", "g", 9.80665),
    ("force", "N", 1.0), ("force", "kN", 1000.0), ("force", "mN", 1e-3),
    ("voltage", "V", 1.0), ("voltage", "mV", 1e-3), ("time", "ms", 1e-3)])
def test_units_convert_to_si_by_hand_values(quantity, unit, factor):
    k, si = to_si(quantity, unit, channel="c")
    assert k == pytest.approx(factor, rel=1e-15) and si == SI_UNITS[quantity]


@pytest.mark.parametrize("quantity, unit", [("force", "V"), ("force", "mV"), ("displacement", "m/s"),
                                            ("velocity", "m/s^2"), ("acceleration", "N"),
                                            ("voltage", "furlong"), ("velocity", "m_per_s")])
def test_a_unit_that_does_not_fit_its_quantity_is_refused_naming_the_channel(quantity, unit):
    with pytest.raises(InputError, match="'laser'"):
        to_si(quantity, unit, channel="laser", file="x.csv")


def test_other_quantities_keep_their_unit_and_names_are_not_units():
    assert to_si("temperature", "degC", channel="t") == (1.0, "degC")
    assert parse_unit("velocity_m_per_s") is None and parse_unit("s2") is None
    assert parse_unit("m_per_s2") is None


def _rig_file(tmp_path):
    n = 400
    t = np.arange(n)
    volts = np.vstack([np.sin(t / 7), 0.5 * np.sin(t / 5), 0.25 * np.cos(t / 5), np.cos(t / 9)])
    return write_run(tmp_path, "rig", volts, block=150), volts


def test_a_rig_run_carries_quantities_and_reads_in_si_with_roles(tmp_path):
    path, volts = _rig_file(tmp_path)
    with h5py.File(path) as f:
        ds = f["entry/data/disp_1"]
        assert ds.attrs["quantity"] == "displacement" and ds.attrs["physical_units"] == "m"
        assert ds.attrs["units"] == "V"                       # raw volts are stored
        md = json.loads(f["entry/metadata_json"][()])
    assert md["drive_channels"] == ["force_ref"]
    assert md["response_channels"] == ["disp_1", "disp_2", "shear_nc"]
    rec = read_channels(path)
    assert [c.name for c in rec.drives] == ["force_ref"]
    d1 = rec.channel("disp_1")
    assert (d1.quantity, d1.units, d1.role) == ("displacement", "m", "response")
    np.testing.assert_allclose(d1.samples, volts[1] * 1.25e-5)          # 80 V/mm by hand
    assert rec.drive("force").units == "N" and rec.sample_rate_hz == 50_000.0
    assert rec.time.shape == (400,)


def test_a_run_file_written_before_quantities_reads_from_its_channel_specs(tmp_path):
    path, volts = _rig_file(tmp_path)
    with h5py.File(path, "r+") as f:                          # as written by older labjoint
        md = json.loads(f["entry/metadata_json"][()])
        for k in ("channel_quantities", "drive_channels", "response_channels"):
            md.pop(k)
        del f["entry/metadata_json"]
        f["entry"].create_dataset("metadata_json", data=json.dumps(md), dtype=h5py.string_dtype())
        for name in ("force_ref", "disp_1", "disp_2", "shear_nc"):
            for a in ("quantity", "physical_units"):
                del f[f"entry/data/{name}"].attrs[a]
    rec = read_channels(path)
    assert {n: (c.quantity, c.units, c.role) for n, c in rec.channels.items()} == {
        "force_ref": ("force", "N", "drive"), "disp_1": ("displacement", "m", "response"),
        "disp_2": ("displacement", "m", "response"), "shear_nc": ("force", "N", "response")}
    run = read_run(path)                                      # the joint pipelines' path
    np.testing.assert_allclose(run.displacement, (volts[1] - volts[2]) * 1.25e-5)
    with open_run(path) as rf:
        assert rf.metadata["drive_channels"] == ["force_ref"]


def test_csv_records_read_through_read_channels(tmp_path):
    p = tmp_path / "r.csv"
    p.write_text("time_s,displacement_m,force_N,velocity_m_per_s\n0,0,1,5\n0.01,1e-6,2,6\n0.02,0,3,7\n")
    rec = read_channels(p)
    assert rec.sample_rate_hz == pytest.approx(100.0)
    v = rec.channel("velocity_m_per_s")
    assert v.quantity == "unknown" and v.units == "" and v.role == "other"   # never "s"
    assert rec.drive().name == "force" and rec.channel("force").samples.tolist() == [1, 2, 3]


def _voltage_driven(tmp_path):
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.csv_import import store_channels

    def spec(name, quantity, unit):
        return ChannelSpec(name, "imported", quantity, unit, 1.0, range_v=np.inf, coupling="DC")
    t = np.arange(2048) / 1024.0
    u = 0.14 * np.sin(2 * np.pi * 8 * t)
    chans = [(spec("input_V", "voltage", "V"), u),
             (spec("laser", "velocity", "m/s"), 1e-3 * np.cos(2 * np.pi * 8 * t))]
    return store_channels(tmp_path / "bert.h5", t, 1024.0, chans,
                          {"frequency_hz": 8.0, "drive_channels": ["input_V"],
                           "response_channels": ["laser"]}, tmp_path / "data", name="Sine_8Hz")


def test_a_voltage_drive_is_never_used_as_a_force(tmp_path):
    path = _voltage_driven(tmp_path)
    with h5py.File(path) as f:
        assert f["entry/data/input_V"].attrs["quantity"] == "voltage"
        assert f["entry/data/input_V"].attrs["units"] == "V"
        assert f["entry/data/laser"].attrs["units"] == "m/s"
    rec = read_channels(path)
    assert rec.drive().name == "input_V" and rec.drive("voltage").units == "V"
    with pytest.raises(InputError, match=r"no force channel: the drive is a voltage \(input_V\)"):
        rec.drive("force")
    with pytest.raises(InputError, match=r"no force channel: the drive is a voltage \(input_V\)"):
        read_run(path)


def test_analyze_refuses_a_voltage_driven_run_in_one_line(tmp_path):
    import subprocess
    import sys

    path = _voltage_driven(tmp_path)
    p = subprocess.run([sys.executable, "-m", "labjoint.cli.main", "analyze", str(path), "--json"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "no force channel: the drive is a voltage (input_V)" in lines[0]


def test_a_force_driven_record_without_displacement_says_what_it_has(tmp_path):
    from labjoint.hardware.interfaces import ChannelSpec
    from labjoint.storage.csv_import import store_channels

    t = np.arange(64) / 64.0
    chans = [(ChannelSpec("F", "imported", "force", "N", 1.0, range_v=np.inf, coupling="DC"), np.sin(t)),
             (ChannelSpec("a", "imported", "acceleration", "m/s^2", 1.0, range_v=np.inf,
                          coupling="DC"), np.cos(t))]
    path = store_channels(tmp_path / "x.uff", t, 64.0, chans, {"drive_channels": ["F"],
                          "response_channels": ["a"]}, tmp_path / "d")
    assert read_channels(path).drive("force").name == "F"
    with pytest.raises(InputError, match=r"no displacement channel: the responses are a \(acceleration\)"):
        read_run(path)
