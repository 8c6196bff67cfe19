"""A drive channel whose quantity is not the model's input (issue 29 item 7): the modal
kind's modal.drive is per volt or per newton, so a force-driven record is refused in a
voltage-driven set and by a model fitted per volt, naming the run and the channel."""

import numpy as np
import pytest

from labjoint.compare.kinds.modal_prepare import prepare_modal
from labjoint.compare.modal_api import check_drives, predict_modal, save_modal
from labjoint.compare.kinds.modal_fit import fit_modal
from labjoint.errors import InputError
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.storage.channels import Channel, ChannelRecord
from labjoint.storage.csv_import import store_channels
from test_modal_model import FS, _basis, _record


def _as_force(rec: ChannelRecord, name: str) -> ChannelRecord:
    """The same record with its drive read as a force (what a user mapping the amplifier's
    volts as newtons, or a stinger force to a per-volt model, hands in)."""
    chans = {k: v for k, v in rec.channels.items() if k != "input_V"}
    chans["stinger_N"] = Channel("stinger_N", rec.channels["input_V"].samples, "force", "N", "drive")
    return ChannelRecord(name, rec.time, FS, chans, dict(rec.metadata))


def test_mixed_drives_refused_and_a_per_volt_model_refuses_a_force(tmp_path):
    basis, modes = _basis()
    f = modes[0]["frequency_hz"] / 2
    rv = _record(f, 1.0, 0.0, seconds=2.5, name="volts")
    mv = prepare_modal(rv, basis, ["tip"], warmup_s=1.5, judge_s=0.5)
    mf = prepare_modal(_as_force(rv, "newtons"), basis, ["tip"], warmup_s=1.5, judge_s=0.5)
    assert mv.metadata["drive_quantity"] == "voltage" and mf.metadata["drive_quantity"] == "force"
    check_drives([mv, mv])
    with pytest.raises(InputError, match=r"run 'newtons': its drive 'stinger_N' is a force.*is a voltage") as e:
        check_drives([mv, mf])
    assert e.value.field == "drive"
    fit = fit_modal("linear_stiffness+viscous", [mv])
    model = tmp_path / "m.json"
    save_modal(fit, [mv], model)
    spec = lambda c: ChannelSpec(c.name, "imported", c.quantity, c.units, 1.0, range_v=np.inf, coupling="DC")  # noqa: E731
    rf = _as_force(rv, "newtons")
    path = store_channels(tmp_path / "f.h5", rf.time, FS, [(spec(c), c.samples) for c in rf.channels.values()],
                          {"frequency_hz": rf.metadata["frequency_hz"], "drive_channels": ["stinger_N"],
                           "response_channels": ["tip", "root"]}, tmp_path / "data", name="newtons")
    with pytest.raises(InputError, match="model's input is a voltage"):
        predict_modal(model, path)
