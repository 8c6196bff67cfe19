"""Simulated instruments: in-memory generator, SimDAQ (interface, rates, overrun injection), open_sim."""

import numpy as np
import pytest

from labjoint.config import load_config
from labjoint.errors import BufferOverrun, ConfigError, HardwareError, InputError
from labjoint.hardware.interfaces import DAQ, SignalGenerator
from labjoint.hardware.sim import MemoryGenerator, SimDAQ, SimRig, open_sim


@pytest.fixture()
def sim():
    gen, daq, rig = open_sim(load_config())
    yield gen, daq, rig
    daq.close()
    gen.close()


def test_memory_generator_implements_the_interface():
    g = MemoryGenerator()
    assert isinstance(g, SignalGenerator) and g.identify()
    s = g.apply(400.0, 19.0, 0.5)
    assert (s.frequency_hz, s.amplitude_vpp, s.offset_v, s.output) == (400.0, 19.0, 0.5, False)
    g.set_output(True)
    assert g.read_settings().output is True
    assert g.read_settings().amplitude_vpp == 19.0
    with g:
        pass
    with pytest.raises(HardwareError):
        g.read_settings()


@pytest.mark.parametrize("args, field", [((0.0, 1.0), "frequency_hz"), ((float("nan"), 1.0), "frequency_hz"),
                                         ((400.0, 25.0), "amplitude_vpp"), ((400.0, -1.0), "amplitude_vpp"),
                                         ((400.0, 10.0, 6.0), "offset_v")])
def test_memory_generator_rejects_out_of_range_settings(args, field):
    g = MemoryGenerator()
    with pytest.raises(InputError) as exc:
        g.apply(*args)
    assert exc.value.field == field
    assert g.read_settings().frequency_hz == 1000.0  # unchanged


def test_close_leaves_output_off():
    g = MemoryGenerator()
    g.apply(400.0, 20.0)
    g.set_output(True)
    g.close()
    assert g._settings.output is False


def test_open_sim_gives_a_daq_in_config_channel_order(sim):
    gen, daq, rig = sim
    rc = load_config()
    assert isinstance(daq, DAQ) and isinstance(rig, SimRig)
    assert [c.name for c in daq.channels] == [c.name for c in rc.daq.channels]
    assert daq.sample_rate_hz == 50000.0
    assert rig.torque_nm == 5.0


def test_read_follows_the_generator_at_every_read(sim):
    gen, daq, rig = sim
    with pytest.raises(HardwareError):
        daq.read(100)
    daq.start()
    quiet = daq.read(5000)
    assert quiet.dtype == np.float64 and quiet.shape == (4, 5000)
    gen.apply(400.0, 20.0)
    gen.set_output(True)
    daq.read(10000)
    loud = daq.read(5000)
    assert np.all(loud.std(axis=1) > 20 * quiet.std(axis=1))
    gen.apply(400.0, 10.0)
    daq.read(10000)
    half = daq.read(5000)
    ratio = half.std(axis=1) / loud.std(axis=1)
    assert np.all((ratio > 0.4) & (ratio < 0.6))
    assert daq.samples_read == 35000
    buf = np.empty((4, 1000))
    assert daq.read(1000, out=buf) is buf
    with pytest.raises(InputError):
        daq.read(10, out=np.empty((3, 10)))


def test_sample_rate_snaps_to_the_module_ladder(sim):
    _, daq, rig = sim
    assert daq.configure(daq.channels, 20000.0) == 25000.0
    assert daq.sample_rate_hz == 25000.0 and rig.substeps == 4
    assert daq.configure(daq.channels, 2000.0) == 2000.0
    for bad in (60000.0, 1000.0):
        with pytest.raises(ConfigError) as exc:
            daq.configure(daq.channels, bad)
        assert exc.value.field == "sample_rate_hz"
    daq.start()
    with pytest.raises(HardwareError):
        daq.configure(daq.channels, 50000.0)


def test_injected_overrun_raises_on_the_read_that_reaches_it(sim):
    _, daq, _ = sim
    daq.start()
    daq.inject_overrun(2500)
    daq.read(1000)
    daq.read(1000)
    with pytest.raises(BufferOverrun):
        daq.read(1000)
    with pytest.raises(BufferOverrun):
        daq.read(10)  # the task stays faulted until restarted
    daq.stop()
    daq.start()
    assert daq.samples_read == 0
    assert daq.read(3000).shape == (4, 3000)


def test_sim_daq_accepts_any_signal_generator():
    rc = load_config()
    _, _, rig = open_sim(rc)
    gen = MemoryGenerator()
    daq = SimDAQ(rig, gen)
    gen.apply(100.0, 2.0)
    gen.set_output(True)
    daq.start()
    daq.read(2000)
    assert rig.true_state().drive_v.max() == pytest.approx(1.0, rel=1e-3)
    daq.close()
    with pytest.raises(HardwareError):
        daq.start()
