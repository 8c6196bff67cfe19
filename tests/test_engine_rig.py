"""open_rig: backends chosen by the config alone; the generator starts with output OFF."""

import shutil

import pytest

from labjoint.acquisition.rig import Rig, open_rig
from labjoint.config import CONFIG_DIR, load_config
from labjoint.errors import HardwareError
from labjoint.hardware.afg1022 import AFG1022

pytest.importorskip("labjoint.hardware.sim.devices")


#: the real backend on rig-sim's channels: a module that switches IEPE off per channel
#: (the NI 9233 would feed the capacitive sensors 2 mA) and drives in its flat band
REAL = {"rig": {"backend": "real"}, "daq": {"module": "NI 9234", "sample_rate_hz": 51200.0},
        "limits": {"min_frequency_hz": 5.0}}

def test_sim_backend_with_pyvisa_sim_drives_the_afg1022_driver():
    cfg = load_config()
    with open_rig(cfg) as rig:
        assert rig.backend == "sim" and isinstance(rig.generator, AFG1022)
        assert rig.daq.generator is rig.generator  # the simulated DAQ reads this instrument
        assert rig.generator.read_settings().output is False
        assert rig.daq.sample_rate_hz == cfg.daq.sample_rate_hz
        assert [c.name for c in rig.daq.channels] == [c.name for c in cfg.daq.channels]
        engine = rig.engine()
        assert engine.rig is rig.sim and engine.limits == cfg.limits and engine.config is cfg
    assert not rig.generator.connected  # close() released the instrument


def test_sim_backend_without_visa_uses_the_in_memory_generator():
    cfg = load_config(overrides={"generator": {"visa_library": ""}})
    with open_rig(cfg) as rig:
        assert type(rig.generator).__name__ == "MemoryGenerator"
        assert rig.daq.generator is rig.generator and rig.sim is not None


def test_instrument_file_beside_a_config_elsewhere_is_found(tmp_path):
    shutil.copy(CONFIG_DIR / "afg1022-sim.yaml", tmp_path / "my-afg.yaml")
    toml = (CONFIG_DIR / "rig-sim.toml").read_text().replace("afg1022-sim.yaml@sim", "my-afg.yaml@sim")
    (tmp_path / "rig.toml").write_text(toml)
    with open_rig(load_config(tmp_path / "rig.toml")) as rig:
        assert isinstance(rig.generator, AFG1022)
        assert rig.generator.identify().startswith("TEKTRONIX,AFG1022")


def test_real_backend_opens_afg1022_and_nidaq(monkeypatch):
    seen = {}

    class FakeNIDAQ:
        @classmethod
        def from_config(cls, daq_config):
            seen["device"] = daq_config.device
            return cls()

        def configure(self, channels, rate):
            seen["configure"] = ([c.name for c in channels], rate)
            return rate

        def close(self):
            seen["closed"] = True

    import labjoint.hardware.nidaq as nidaq

    monkeypatch.setattr(nidaq, "NIDAQ", FakeNIDAQ)
    cfg = load_config(overrides=REAL)  # generator still on pyvisa-sim
    rig = open_rig(cfg)
    try:
        assert isinstance(rig, Rig) and rig.sim is None and isinstance(rig.generator, AFG1022)
        assert isinstance(rig.daq, FakeNIDAQ) and rig.generator.read_settings().output is False
        assert seen["device"] == "cDAQ1Mod1"
        assert seen["configure"] == (["force_ref", "disp_1", "disp_2", "shear_nc"], 51200.0)
    finally:
        rig.close()
    assert seen["closed"] and not rig.generator.connected


def test_real_backend_releases_the_generator_when_the_daq_fails(monkeypatch):
    import labjoint.hardware.nidaq as nidaq

    def no_driver(self, channels, rate):
        raise HardwareError("NI-DAQmx driver not installed (as on this test machine)")

    monkeypatch.setattr(nidaq.NIDAQ, "configure", no_driver)
    opened = []
    real_open = AFG1022.from_config.__func__

    def spy(cls, *a, **k):
        gen = real_open(cls, *a, **k)
        opened.append(gen)
        return gen

    monkeypatch.setattr(AFG1022, "from_config", classmethod(spy))
    cfg = load_config(overrides=REAL)
    with pytest.raises(HardwareError, match="NI-DAQmx"):
        open_rig(cfg)
    assert len(opened) == 1 and not opened[0].connected  # the generator was released
