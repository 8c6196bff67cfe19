"""The UNESP-BERT file (../shared/data/bert/bert.h5, read in place) imports with the one
map configs/maps/bert.toml: one run file per test, every channel with the right quantity
and unit, the drive in volts (never newtons), the sine frequency from the group name,
Testlab's FRFs with their quantity pair; analyze refuses the voltage-driven runs."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.storage.importers import read_frf
from labjoint.storage.reader import read_channels

BERT = Path("/work/shared/data/bert/bert.h5")
MAP = Path(__file__).resolve().parent.parent / "configs" / "maps" / "bert.toml"
UNITS = {"input_V": ("voltage", "V", "drive"), "laser": ("velocity", "m/s", "response"),
         **{f"acc{i}": ("acceleration", "m/s^2", "response") for i in range(1, 5)}}

pytestmark = [pytest.mark.skipif(not BERT.is_file(), reason="the BERT data are not on this machine"),
              pytest.mark.slow]          # 18 MB, 20 run files: 6-12 s depending on the load


def test_the_bert_file_imports_with_its_one_map(tmp_path, capsys):
    assert main(["import", str(BERT), "--map", str(MAP), "--out", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    names = sorted(Path(p).stem for p in out["runs"])
    with h5py.File(BERT) as f:
        assert names == sorted(f)                       # every group: 16 records, 4 FRFs
        laser = np.asarray(f["Sine_Sine_09p5Hz/laser_m_per_s"][()], float)
        volts = np.asarray(f["Rand_Rand0p25/input_V"][()], float)
        h_testlab = f["frf_Rand_Rand0p25/re"][()] + 1j * f["frf_Rand_Rand0p25/im"][()]
    for p in out["runs"]:
        rec = read_channels(p)
        assert {n: (c.quantity, c.units, c.role) for n, c in rec.channels.items()} == \
            {n: UNITS[n] for n in rec.channels}
        assert all(c.quantity != "force" for c in rec.channels.values())
        assert rec.metadata["torque_nm"] == 5.0 if "frf" not in rec.name else True
        with h5py.File(p) as f:
            for n in rec.channels:
                a = f[f"entry/data/{n}"].attrs
                assert (a["quantity"], a["units"]) == UNITS[n][:2]
    sine = read_channels(tmp_path / "Sine_Sine_09p5Hz.h5")
    assert sine.metadata["frequency_hz"] == 9.5 and sine.sample_rate_hz == 1024.0
    np.testing.assert_array_equal(sine.channel("laser").samples, laser)
    assert read_channels(tmp_path / "Sine_Sine_05p5Hz.h5").metadata["frequency_hz"] == 5.5
    rand = read_channels(tmp_path / "Rand_Rand0p25.h5")
    assert "frequency_hz" not in rand.metadata and rand.time[-1] == pytest.approx(16 - 1 / 1024)
    assert rand.metadata["level"] == 0.25
    assert read_channels(tmp_path / "frf_Rand_Rand0p30.h5").metadata["level"] == 0.30
    np.testing.assert_array_equal(rand.drive("voltage").samples, volts)
    frf = read_frf(tmp_path / "frf_Rand_Rand0p25.h5")
    assert (frf.units, frf.response_quantity, frf.drive_quantity) == ("m/s/V", "velocity", "voltage")
    np.testing.assert_array_equal(frf.h[0], h_testlab)
    band = (frf.frequency_hz > 10) & (frf.frequency_hz < 30)
    assert frf.frequency_hz[band][np.argmax(np.abs(frf.h[0][band]))] == pytest.approx(18.75)

    assert main(["analyze", str(tmp_path / "Sine_Sine_09p5Hz.h5"), "--json"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and "no force channel: the drive is a voltage (input_V)" in cap.err
    assert len(cap.err.strip().splitlines()) == 1
