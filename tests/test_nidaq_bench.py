"""Issue 18, DAQ side: IEPE on the NI 9233, its AC-coupled flat band, committing the task
before any output, recovering from a lost USB cDAQ, and stamping the task start. The
NI-DAQmx C library is absent: nidaqmx.Task is an autospec of the real class, raising the
real DaqError codes (tests/test_nidaq.py's Rig)."""

from dataclasses import replace
from unittest import mock

import pytest
from nidaqmx.constants import ExcitationSource, TaskMode
from nidaqmx.error_codes import DAQmxErrors
from nidaqmx.errors import DaqError, DaqReadError

from labjoint.config import CONFIG_DIR, load_config
from labjoint.errors import ConfigError, HardwareError
from labjoint.hardware.nidaq import NIDAQ, DeviceLost, check_channels, check_drive_band
from test_nidaq import SPECS, rig  # noqa: F401  (the autospec fixture)

SIM = load_config().daq.specs()  # force_ref IEPE; disp_1, disp_2 capacitive, shear_nc: iepe false


# ---- item 8: a module that excites every input refuses non-IEPE channels ------------------
def test_9233_refuses_capacitive_channels_it_would_feed_2_ma(rig):  # noqa: F811
    with pytest.raises(ConfigError, match="NI 9233 sources 2 mA IEPE current on every input") as info:
        NIDAQ(module="NI 9233").configure(SIM, 50000.0)
    assert info.value.field == "daq.channels.disp_1.iepe"
    assert rig.log.mock_calls == []  # refused before any task exists


def test_9234_switches_excitation_off_explicitly_on_non_iepe_channels(rig):  # noqa: F811
    NIDAQ(module="NI 9234").configure(SIM, 51200.0)
    calls = rig.log.mock_calls
    for spec in SIM:
        want = ExcitationSource.INTERNAL if spec.iepe else ExcitationSource.NONE
        assert getattr(mock.call, f"{spec.name}.ai_excit_src")(want) in calls


def test_the_real_rig_config_passes_the_module_check():
    cfg = load_config(CONFIG_DIR / "rig-real.toml")
    check_channels(cfg.daq.module, cfg.daq.specs())
    check_drive_band(cfg.daq.module, cfg.daq.specs(), cfg.daq.sample_rate_hz,
                     cfg.limits.min_frequency_hz, cfg.limits.max_frequency_hz)


# ---- item 9: drive frequencies stay where the AC-coupled inputs are flat -----------------
@pytest.mark.parametrize("lo, hi, field", [(1.0, 5000.0, "limits.min_frequency_hz"),
                                           (5.0, 30000.0, "limits.max_frequency_hz")])
def test_drive_band_outside_the_flat_response_is_refused(lo, hi, field):
    with pytest.raises(ConfigError) as info:
        check_drive_band("NI 9233", SPECS, 50000.0, lo, hi)
    assert info.value.field == field


def test_dc_coupled_channels_have_no_low_corner():
    dc = [replace(s, coupling="DC", iepe=False) for s in SPECS]
    check_drive_band("NI 9239", dc, 50000.0, 0.1, 5000.0)


# ---- item 10: configuration errors surface in configure(), before any output ------------
def test_configure_commits_the_task_and_reports_what_the_driver_refused(rig):  # noqa: F811
    rig.task.control.side_effect = DaqError("Specified property is not supported by the "
                                            "device or is not applicable to the task.",
                                            DAQmxErrors.ATTRIBUTE_NOT_SUPPORTED_IN_TASK_CONTEXT.value)
    with pytest.raises(HardwareError, match="configuring the task failed"):
        NIDAQ().configure(SPECS, 50000.0)
    rig.task.control.assert_called_once_with(TaskMode.TASK_COMMIT)
    rig.task.close.assert_called_once()


# ---- item 11: a lost USB device: task closed, configured again before the next start -----
@pytest.mark.parametrize("code", [-50405, -201003, -200045])
def test_lost_device_is_reported_and_reconfigured_at_the_next_start(rig, code):  # noqa: F811
    daq = NIDAQ()
    daq.configure(SPECS, 50000.0)
    daq.start()
    daq.read(100)
    rig.reader.read_many_sample.side_effect = DaqReadError("device gone", code, 0)
    with pytest.raises(DeviceLost, match=f"lost \\(DAQmx {code}\\) after 100 samples") as info:
        daq.read(100)
    assert daq.lost and info.value.samples_read == 100
    rig.task.close.assert_called_once()
    rig.reader.read_many_sample.side_effect = None
    rig.reader.read_many_sample.return_value = 100
    daq.start()  # a new task, configured and committed again, then started
    names = [c[0] for c in rig.log.mock_calls]
    assert names.count("Task") == 2 and names.count("task.control") == 2
    assert not daq.lost and daq.read(100).shape == (4, 100)


def test_device_still_missing_at_start_says_lost(rig):  # noqa: F811
    daq = NIDAQ()
    daq.configure(SPECS, 50000.0)
    daq.start()
    rig.reader.read_many_sample.side_effect = DaqReadError("gone", -200045, 0)
    with pytest.raises(DeviceLost):
        daq.read(10)
    rig.task.control.side_effect = DaqError("Device cannot be accessed.", -201003)
    with pytest.raises(DeviceLost, match="-201003"):
        daq.start()
    assert daq.lost


# ---- item 12: the host time of sample 0 ----------------------------------------------
def test_start_stamps_the_host_clock_around_task_start(rig):  # noqa: F811
    ticks = iter([1000.0, 1000.25])
    daq = NIDAQ(wall_clock=lambda: next(ticks))
    daq.configure(SPECS, 50000.0)
    daq.start()
    assert daq.started_at == 1000.125 and daq.started_at_uncertainty_s == 0.25
