"""The safety hook alone: settings and block checks name the limit and the value."""

import numpy as np
import pytest

from labjoint.acquisition.safety import LimitTrip, check_block, check_settings
from labjoint.config import LimitsConfig
from labjoint.errors import LimitExceeded
from labjoint.hardware.interfaces import ChannelSpec, GeneratorSettings

LIM = LimitsConfig(max_vpp=10.0, min_frequency_hz=5.0, max_frequency_hz=2000.0,
                   max_displacement_m=50e-6, max_force_n=400.0)
CH = [ChannelSpec("force_ref", "force", "force", "N", 50.0),
      ChannelSpec("disp_1", "capacitive", "displacement", "m", 1.25e-5),
      ChannelSpec("disp_2", "capacitive", "displacement", "m", 1.25e-5),
      ChannelSpec("shear_nc", "nanocomposite", "force", "N", 301.0,
                  calibration=((100.0, 200.0), (400.0, 300.0))),
      ChannelSpec("drive", "voltage", "voltage", "V", 1.0)]


@pytest.mark.parametrize("settings, limit", [
    (GeneratorSettings(400.0, 10.5), "max_vpp"),
    (GeneratorSettings(400.0, -1.0), "max_vpp"),
    (GeneratorSettings(400.0, float("nan")), "max_vpp"),
    (GeneratorSettings(4.0, 1.0), "min_frequency_hz"),
    (GeneratorSettings(2500.0, 1.0), "max_frequency_hz"),
    (GeneratorSettings(400.0, 1.0, float("inf")), "offset_v"),
])
def test_settings_outside_limits_are_refused(settings, limit):
    with pytest.raises(LimitTrip) as err:
        check_settings(settings, LIM)
    assert err.value.limit == limit and isinstance(err.value, LimitExceeded)
    assert limit in str(err.value)


def test_settings_on_the_bounds_pass():
    check_settings(GeneratorSettings(5.0, 10.0), LIM)
    check_settings(GeneratorSettings(2000.0, 0.0), LIM)


def block(force_v=0.0, d1_v=0.0, d2_v=0.0, nc_v=0.0, drive_v=0.0, n=100):
    s = np.sin(np.linspace(0, 2 * np.pi, n))
    return np.vstack([force_v * s, d1_v * s, d2_v * s, nc_v * s, drive_v * s])


def test_block_within_limits_passes_and_voltage_channels_are_ignored():
    check_block(block(force_v=7.9, d1_v=1.9, d2_v=-1.9, nc_v=1.0, drive_v=100.0), CH, LIM, 400.0)


def test_displacement_per_channel_and_relative():
    # 3 V * 12.5 um/V = 37.5 um on each beam: fine alone, 75 um relative in antiphase
    v = block(d1_v=3.0, d2_v=-3.0)
    check_block(v, CH, LIM, 400.0)
    with pytest.raises(LimitTrip) as err:
        check_block(v, CH, LIM, 400.0, relative=("disp_1", "disp_2"))
    e = err.value
    assert e.limit == "max_displacement_m" and e.channel == "disp_1-disp_2"
    assert e.value == pytest.approx(75e-6, rel=1e-3) and e.bound == 50e-6
    assert abs(v[1, e.index]) == np.abs(v[1]).max()  # index of the largest excursion
    check_block(block(d1_v=3.0, d2_v=3.0), CH, LIM, 400.0, relative=("disp_1", "disp_2"))  # in phase: 0
    with pytest.raises(LimitTrip, match="disp_2"):
        check_block(block(d2_v=4.5), CH, LIM)


def test_force_uses_the_calibration_at_the_drive_frequency():
    v = block(nc_v=1.6)  # 480 N at 400 Hz (300 N/V), 320 N at 100 Hz (200 N/V)
    check_block(v, CH, LIM, 100.0)
    with pytest.raises(LimitTrip) as err:
        check_block(v, CH, LIM, 400.0)
    assert err.value.channel == "shear_nc" and err.value.value == pytest.approx(480.0, rel=1e-3)
    with pytest.raises(LimitTrip, match="force_ref"):
        check_block(block(force_v=8.1), CH, LIM, 400.0)


def test_nan_samples_trip():
    v = block(d1_v=0.1)
    v[1, 10] = np.nan
    with pytest.raises(LimitTrip):
        check_block(v, CH, LIM)
