"""`labjoint hw check`: instruments and DAQ devices seen, NI-DAQmx absence said plainly."""

import shutil
from unittest import mock

import nidaqmx.system
import nidaqmx.types
import pytest
import pyvisa
from nidaqmx.errors import DaqNotFoundError

from labjoint.config import CONFIG_DIR, load_config
from labjoint.hardware.afg1022 import AFG1022
from labjoint.hardware.check import NO_NIDAQMX, format_check, hardware_check

RES = "USB0::0x0699::0x0353::SIM0001::INSTR"


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "afg1022-sim.yaml"
    shutil.copy(CONFIG_DIR / "afg1022-sim.yaml", path)
    return load_config(None, {"generator": {"visa_library": f"{path}@sim"}})


@pytest.fixture
def no_driver():
    err = DaqNotFoundError("Could not find an installation of NI-DAQmx.")
    with mock.patch.object(nidaqmx.system.System, "local", side_effect=err):
        yield


def test_without_the_ni_driver_the_check_says_so_plainly(config, no_driver):
    result = hardware_check(config)
    n = result["nidaqmx"]
    assert n["driver_installed"] is False and n["devices"] == []
    assert n["message"] == NO_NIDAQMX
    assert result["daq"]["found"] is None
    text = format_check(result)
    assert "NI-DAQmx driver not installed" in text
    assert "cannot look for it without the driver" in text


def test_on_this_machine_without_ni_daqmx_the_real_library_is_reported_absent(config):
    # The NI-DAQmx C library is not installed on these machines (nidaqmx raises).
    with pytest.raises(DaqNotFoundError):
        nidaqmx.system.System.local()
    assert hardware_check(config)["nidaqmx"]["message"] == NO_NIDAQMX


def test_lists_the_simulated_generator_and_its_identity(config, no_driver):
    result = hardware_check(config)
    sim = [b for b in result["visa"] if b["library"].endswith("@sim")]
    assert len(sim) == 1 and any("SIM0001" in r for r in sim[0]["resources"])
    g = result["generator"]
    assert g["reachable"] and g["simulated"] and "AFG1022" in g["idn"]
    assert "AFG1022" in format_check(result)


def test_check_leaves_a_running_output_alone(config, no_driver):
    lib = config.generator.visa_library
    with AFG1022(RES, lib) as gen:
        gen.apply(400.0, 5.0)
        gen.set_output(True)
        hardware_check(config)
        assert gen.read_settings().output is True


def test_unreachable_generator_is_reported_not_raised(tmp_path, no_driver):
    path = tmp_path / "afg1022-sim.yaml"
    shutil.copy(CONFIG_DIR / "afg1022-sim.yaml", path)
    cfg = load_config(None, {"generator": {"visa_library": f"{path}@sim",
                                           "resource": "USB0::0x0699::0x0353::GONE::INSTR"}})
    g = hardware_check(cfg)["generator"]
    assert not g["reachable"] and "GONE" in g["error"]
    assert "not reachable" in format_check(hardware_check(cfg))


def test_with_a_driver_devices_are_listed_and_matched_to_the_config(config):
    system = mock.create_autospec(nidaqmx.system.System, instance=True)
    system.driver_version = nidaqmx.types.DriverVersion(2024, 1, 0)
    mod = mock.Mock(product_type="NI 9234", dev_serial_num=0x1A2B)
    mod.name = "cDAQ1Mod1"
    chassis = mock.Mock(product_type="cDAQ-9174", dev_serial_num=0)
    chassis.name = "cDAQ1"
    system.devices = [chassis, mod]
    with mock.patch.object(nidaqmx.system.System, "local", return_value=system):
        result = hardware_check(config)
    n = result["nidaqmx"]
    assert n["driver_installed"] and n["driver_version"] == "2024.1.0"
    assert [d["name"] for d in n["devices"]] == ["cDAQ1", "cDAQ1Mod1"]
    assert result["daq"]["found"] is True
    assert "NI 9234" in result["daq"]["warning"]  # config says NI 9233
    text = format_check(result)
    assert "cDAQ1Mod1: NI 9234 1A2B" in text and "warning" in text


def test_without_config_only_backends_are_listed(no_driver):
    result = hardware_check()
    assert result["generator"] is None and "daq" not in result
    assert result["visa"][0]["library"] == "(default)"
    assert isinstance(result["visa"][0]["available"], bool)
    if not result["visa"][0]["available"]:
        assert result["visa"][0]["error"]


def test_missing_default_visa_is_reported(no_driver):
    with mock.patch.object(pyvisa, "ResourceManager",
                           side_effect=ValueError("Could not locate a VISA implementation.")):
        b = hardware_check()["visa"][0]
    assert not b["available"] and "no usable VISA library" in b["error"]


# ---- issue 18 ---------------------------------------------------------------------------
def test_pyvisa_py_value_error_is_reported_as_not_reachable_and_exit_3(tmp_path, no_driver, monkeypatch,
                                                                       capsys):
    import json

    import pyvisa.highlevel

    from labjoint.cli.main import main

    def no_device(self, *args, **kwargs):  # pyvisa-py without libusb, or no device on the bus
        raise ValueError("No backend available")

    monkeypatch.setattr(pyvisa.highlevel.ResourceManager, "open_resource", no_device)
    path = tmp_path / "afg1022-sim.yaml"
    shutil.copy(CONFIG_DIR / "afg1022-sim.yaml", path)
    cfg = tmp_path / "rig.toml"
    cfg.write_text((CONFIG_DIR / "rig-real.toml").read_text().replace(
        'visa_library = ""', f'visa_library = "{path}@sim"'))
    assert main(["hw", "check", "--config", str(cfg), "--json"]) == 3
    res = json.loads(capsys.readouterr().out)
    g = res["generator"]
    assert not g["reachable"] and "not reachable" in g["error"] and "ValueError" in g["error"]
    assert res["ok"] is False and len(res["problems"]) == 2  # nothing reachable: both named
    assert any("generator" in p for p in res["problems"]) and any("DAQ" in p for p in res["problems"])


def test_the_load_probe_is_reported(config, no_driver):
    g = hardware_check(config)["generator"]
    assert g["reachable"] and g["load_settable"] is False and g["load"] == "INF"
    assert "set it on the front panel" in format_check(hardware_check(config))


def test_a_channel_set_the_module_cannot_take_is_a_problem_on_the_real_rig(tmp_path):
    system = mock.create_autospec(nidaqmx.system.System, instance=True)
    system.driver_version = nidaqmx.types.DriverVersion(2024, 1, 0)
    mod = mock.Mock(product_type="NI 9233", dev_serial_num=0x1A2B)
    mod.name = "cDAQ1Mod1"
    system.devices = [mod]
    path = tmp_path / "afg1022-sim.yaml"
    shutil.copy(CONFIG_DIR / "afg1022-sim.yaml", path)
    cfg = load_config(CONFIG_DIR / "rig-real.toml", {
        "generator": {"visa_library": f"{path}@sim", "resource": RES},
        "daq": {"module": "NI 9233", "sample_rate_hz": 50000.0}})
    with mock.patch.object(nidaqmx.system.System, "local", return_value=system):
        result = hardware_check(cfg)
    assert result["generator"]["reachable"] and result["daq"]["found"] is True
    assert result["ok"] is False
    assert "2 mA IEPE current on every input" in result["daq"]["config_error"]
    assert "config:" in format_check(result)


def test_the_sim_rigs_in_memory_generator_needs_no_visa(no_driver):
    cfg = load_config(None, {"generator": {"visa_library": ""}})
    result = hardware_check(cfg)
    assert result["generator"]["needed"] is False and result["ok"] is True
