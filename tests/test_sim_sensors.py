"""Simulated sensors and DAQ input stage: ADC, clipping, coupling, nanocomposite response, noise."""

import numpy as np
import pytest

from labjoint.errors import ConfigError
from labjoint.hardware.interfaces import ChannelSpec, GeneratorSettings
from labjoint.hardware.sim import SimConfig, SimRig, nanocomposite_true_factor

QUIET = {"sensors": {"force_noise_n": 0.0, "displacement_noise_m": 0.0, "nanocomposite_noise_n": 0.0,
                     "voltage_noise_v": 0.0, "daq_noise_v": 0.0}}


def channels(coupling="AC", disp_sensitivity=1.25e-5):
    return [
        ChannelSpec("force_ref", "force", "force", "N", 50.0, coupling=coupling),
        ChannelSpec("disp_1", "capacitive", "displacement", "m", disp_sensitivity, coupling=coupling),
        ChannelSpec("disp_2", "capacitive", "displacement", "m", 1.25e-5, coupling=coupling),
        ChannelSpec("shear_nc", "nanocomposite", "force", "N", 301.0, coupling=coupling),
    ]


def lock_in(x, f, fs):
    t = np.arange(len(x)) / fs
    return 2 * np.mean(x * np.exp(-2j * np.pi * f * t))


def test_quantisation_step_is_10_v_over_2_pow_24():
    rig = SimRig(SimConfig.from_dict({}), channels(), 50000.0)
    v = rig.advance(5000, GeneratorSettings(400.0, 2.0, 0.0, True))
    step = 10.0 / 2**24
    codes = v / step
    np.testing.assert_allclose(codes, np.rint(codes), atol=1e-6)
    assert np.min(np.diff(np.unique(v[0]))) == pytest.approx(step)


def test_clipping_at_the_input_range():
    rig = SimRig(SimConfig.from_dict(QUIET), channels(disp_sensitivity=1e-8), 50000.0)
    v = rig.advance(5000, GeneratorSettings(400.0, 20.0, 0.0, True))
    step = 10.0 / 2**24
    assert v[1].max() == pytest.approx(5.0 - step) and v[1].min() == pytest.approx(-5.0)
    assert np.mean(np.abs(v[1]) >= 5.0 - step) > 0.3
    assert np.abs(v[2]).max() < 5.0  # the other channels are unaffected


def test_ac_coupling_removes_dc_and_dc_coupling_passes_it():
    sim = {**QUIET, "effects": [{"name": "offset", "F0": 40.0}]}
    s = GeneratorSettings(400.0, 4.0, 1.0, True)  # 1 V generator offset: static push on the beams
    out = {}
    for coupling, module in (("AC", "NI 9233"), ("DC", "NI 9234")):
        rig = SimRig(SimConfig.from_dict({**sim, "module_name": module}), channels(coupling), 10000.0)
        rig.advance(30000, s)  # 3 s: ~9 time constants of the 0.5 Hz high-pass
        v = rig.advance(5000, s)
        out[coupling] = (v.mean(axis=1), rig.true_state())
    dc_v, ts = out["DC"]
    ac_v, _ = out["AC"]
    u_dc = np.mean(ts.u)
    assert u_dc > 0.2e-6  # the joint carries the static push
    assert (dc_v[1] - dc_v[2]) * 1.25e-5 == pytest.approx(u_dc, rel=1e-3)
    assert abs(ac_v[1] - ac_v[2]) * 1.25e-5 < 1e-3 * u_dc
    # the preload is DC in the joint force: the nanocomposite passes it with its DC sensitivity
    assert dc_v[3] == pytest.approx(np.mean(ts.sensed["shear_nc"]) / nanocomposite_true_factor(0.0), rel=1e-3)
    assert abs(ac_v[3]) < 1e-3 * abs(dc_v[3])


def test_dc_coupling_needs_a_module_that_offers_it():
    with pytest.raises(ConfigError) as exc:
        SimRig(SimConfig.from_dict({"module_name": "NI 9233"}), channels("DC"), 50000.0)
    assert exc.value.field == "channels.force_ref.coupling"


@pytest.mark.parametrize("f, fs, settle, record", [(400.0, 51200.0, 0.2, 0.1), (2000.0, 51200.0, 0.2, 0.1),
                                                   (10.0, 2048.0, 0.5, 1.0)])
def test_nanocomposite_reads_joint_force_through_its_true_factor(f, fs, settle, record):
    rig = SimRig(SimConfig.from_dict({**QUIET, "module_name": "NI 9234"}), channels("DC"), fs)
    s = GeneratorSettings(f, 5.0, 0.0, True)
    rig.advance(int(settle * fs), s)
    v = rig.advance(int(record * fs), s)
    force = rig.true_state().sensed["shear_nc"]
    factor = abs(lock_in(force, f, fs) / lock_in(v[3], f, fs))
    assert factor == pytest.approx(float(nanocomposite_true_factor(f)), rel=2e-3)
    if f == 400.0:
        assert factor == pytest.approx(301.0, rel=1e-3)
        assert abs(np.degrees(np.angle(lock_in(v[3], f, fs) / lock_in(force, f, fs)))) < 0.5
    else:
        assert abs(factor / 301.0 - 1) > 0.01  # the sensitivity changes with frequency


def test_nanocomposite_is_roughly_flat_in_band_and_differs_outside():
    band = nanocomposite_true_factor(np.array([50.0, 100.0, 400.0, 1000.0, 1500.0]))
    assert np.all(np.abs(band / 301.0 - 1) < 0.02)
    assert abs(nanocomposite_true_factor(2.0) / 301.0 - 1) > 0.2   # piezoresistive shelf
    assert nanocomposite_true_factor(12000.0) < 0.5 * 301.0          # layer resonance


def test_noise_rms_per_channel_matches_config():
    sensors = {"force_noise_n": 0.05, "displacement_noise_m": 4e-9, "nanocomposite_noise_n": 0.5,
               "daq_noise_v": 2e-5}
    rig = SimRig(SimConfig.from_dict({"sensors": sensors}), channels(), 50000.0)
    v = rig.advance(40000, GeneratorSettings(400.0, 20.0, 0.0, False))  # output off: rig at rest
    expected = np.sqrt(np.array([0.05 / 50.0, 4e-9 / 1.25e-5, 4e-9 / 1.25e-5, 0.5 / 301.0]) ** 2 + 2e-5**2)
    np.testing.assert_allclose(v.std(axis=1), expected, rtol=0.03)
    assert abs(np.corrcoef(v)[0, 1]) < 0.05  # independent channels
