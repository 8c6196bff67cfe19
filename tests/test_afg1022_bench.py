"""Issue 18, generator side: what the real AFG1022 and its USB link do that a permissive
twin hid. The twin (configs/afg1022-sim.yaml) is strict; the link's quirks are played by
a proxy around the twin's VISA resource (the VISA boundary), raising pyvisa's own errors."""

import logging
import math
import shutil

import pytest
import pyvisa
import pyvisa.constants
import pyvisa.errors
import pyvisa.highlevel

from labjoint.acquisition.drive import AbortSignal, Drive
from labjoint.config import CONFIG_DIR, LimitsConfig, load_config
from labjoint.errors import HardwareError, InstrumentTimeout
from labjoint.hardware.afg1022 import AFG1022

RES = "USB0::0x0699::0x0353::SIM0001::INSTR"
LOAD_PROPERTY = '''          load:
            default: "50"
            getter:
              q: "OUTPut{ch_id}:IMPedance?"
              r: "{:s}"
            setter:
              q: "OUTPut{ch_id}:IMPedance {:s}"
            specs:
              type: str
              valid: ["50", INFinity]
'''


@pytest.fixture
def lib(tmp_path):
    path = tmp_path / "afg1022-sim.yaml"
    shutil.copy(CONFIG_DIR / "afg1022-sim.yaml", path)
    return f"{path}@sim"


def peek(lib, cmd, write=False):
    r = pyvisa.ResourceManager(lib).open_resource(RES, read_termination="\n", write_termination="\n")
    try:
        return r.write(cmd) if write else r.query(cmd).strip()
    finally:
        r.close()


class Link:
    """The USB link as the driver sees it: the twin's resource plus the quirks a test
    turns on, and a log of every exchange ('w'rite, 'q'uery, 'clear')."""

    def __init__(self, inner, log):
        self.inner, self.log = inner, log
        self.empty_idn = 0          # answer the next N *IDN? with ''
        self.vrms_readback = False  # front panel in Vrms: AMPLitude? answers in Vrms units
        self.timeout_on = None      # query text that times out once

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def __setattr__(self, name, value):
        if name == "timeout":
            self.inner.timeout = value
        else:
            object.__setattr__(self, name, value)

    def write(self, cmd):
        self.log.append(("w", cmd))
        return self.inner.write(cmd)

    def query(self, cmd):
        self.log.append(("q", cmd))
        if cmd == "*IDN?" and self.empty_idn:
            self.empty_idn -= 1
            return "\n"
        if cmd == self.timeout_on:
            self.timeout_on = None
            raise pyvisa.errors.VisaIOError(pyvisa.constants.StatusCode.error_timeout)
        answer = self.inner.query(cmd)
        if cmd.endswith("AMPLitude?") and self.vrms_readback:
            unit = self.inner.query(cmd.split(":")[0] + ":VOLTage:UNIT?").strip()
            if unit == "VRMS":
                return f"{float(answer) / (2 * math.sqrt(2)):.12E}"
        return answer

    def clear(self):
        self.log.append(("clear", ""))


class ListWithLog(list):
    """The links opened so far, with the shared exchange ``log`` and the quirks ``cfg``."""


@pytest.fixture
def links(monkeypatch):
    """Every resource the driver opens is wrapped in a :class:`Link`; ``links`` lists them."""
    made, log = ListWithLog(), []
    real_open = pyvisa.highlevel.ResourceManager.open_resource

    def open_resource(self, *args, **kwargs):
        link = Link(real_open(self, *args, **kwargs), log)
        for k, v in getattr(links_cfg, "quirks", {}).items():
            object.__setattr__(link, k, v)
        made.append(link)
        return link

    links_cfg = type("Cfg", (), {"quirks": {}})()
    monkeypatch.setattr(pyvisa.highlevel.ResourceManager, "open_resource", open_resource)
    made.log, made.cfg = log, links_cfg
    return made


# ---- item 1: every VISA failure says "not reachable: why" ------------------------------
def test_pyvisa_py_value_error_on_open_is_not_reachable(monkeypatch, lib):
    def no_device(self, *args, **kwargs):  # pyvisa-py without libusb / with no device
        raise ValueError("No device found.")

    monkeypatch.setattr(pyvisa.highlevel.ResourceManager, "open_resource", no_device)
    with pytest.raises(HardwareError, match=r"SIM0001::INSTR not reachable: .*ValueError: No device found"):
        AFG1022.open(RES, lib)


# ---- item 2: OUTPut:IMPedance probed once, never sent where unsupported --------------
def test_strict_twin_refuses_the_load_and_the_driver_falls_back_to_the_config(lib, links, caplog,
                                                                              monkeypatch):
    import labjoint.hardware.afg1022_session as session
    monkeypatch.setattr(session, "_LOAD_PROBES", {})            # a fresh process
    with caplog.at_level(logging.INFO, logger="labjoint.hardware.afg1022"):
        AFG1022.open(RES, lib, timeout_ms=500).close()
        gen = AFG1022.open(RES, lib, timeout_ms=500)
    try:
        assert gen.load_settable is False and gen.load == "INF"
        said = [r for r in caplog.records if "IMPedance is not supported" in r.getMessage()]
        # once per instrument and process, and the simulated twin is no cause for a warning
        assert len(said) == 1 and said[0].levelno == logging.INFO
        s = gen.apply(400.0, 4.0)
        assert (s.frequency_hz, s.amplitude_vpp) == (400.0, 4.0)
        assert not [c for k, c in links.log if k == "w" and "IMPedance" in c]
        assert peek(lib, "SYSTem:ERRor?").startswith("0")  # the probe left no error behind
    finally:
        gen.close()


def test_where_the_instrument_takes_the_load_it_is_set_and_read_back(tmp_path):
    text = (CONFIG_DIR / "afg1022-sim.yaml").read_text()
    path = tmp_path / "afg-with-load.yaml"
    path.write_text(text.replace("          output:\n", LOAD_PROPERTY + "          output:\n"))
    lib = f"{path}@sim"
    with AFG1022(RES, lib) as gen:
        assert gen.load_settable is True
        gen.apply(400.0, 4.0)
        assert peek(lib, "OUTPut1:IMPedance?") == "INFinity"


# ---- item 3: device clear, *IDN? retry, *OPC? after groups of writes -------------------
def test_connect_clears_the_device_and_retries_an_empty_idn(lib, links):
    links.cfg.quirks = {"empty_idn": 1}
    with AFG1022(RES, lib) as gen:
        assert "AFG1022" in gen.identify()
    log = links.log
    assert log[0] == ("clear", "")
    assert [c for k, c in log[:4] if k == "q"][:2] == ["*IDN?", "*IDN?"]


def test_every_group_of_writes_ends_with_opc_before_the_error_queue(lib, links):
    with AFG1022(RES, lib, timeout_ms=500) as gen:
        del links.log[:]
        gen.apply(400.0, 4.0, 0.5)
        log = links.log
        last_write = max(i for i, (k, _) in enumerate(log) if k == "w")
        assert log[last_write + 1] == ("q", "*OPC?")
        assert log[last_write + 2] == ("q", "SYSTem:ERRor?")


def test_a_timeout_clears_the_device_before_switching_off_and_reopens(lib, links):
    gen = AFG1022.open(RES, lib, timeout_ms=500)
    try:
        gen.apply(400.0, 5.0)
        gen.set_output(True)
        links[0].timeout_on = "SOURce1:FREQuency:FIXed?"
        del links.log[:]
        with pytest.raises(InstrumentTimeout, match="output switched OFF"):
            gen.read_settings()
        kinds = [(k, c) for k, c in links.log]
        i_clear = kinds.index(("clear", ""))
        assert ("w", "OUTPut1:STATe OFF") in kinds[i_clear:]
        assert gen.read_settings().output is False  # through a fresh session
        assert len(links) == 2
    finally:
        gen.close()


# ---- item 4: ramps send only the amplitude ---------------------------------------------
def test_ramp_steps_send_only_the_amplitude(lib, links):
    t = [0.0]
    gen = AFG1022.open(RES, lib, timeout_ms=500)
    try:
        drive = Drive(gen, LimitsConfig(ramp_vpp_per_s=10.0), AbortSignal(),
                      acquire=lambda n: None, changed=lambda: None,
                      sample_rate_hz=lambda: 10000.0, clock=lambda: t[0],
                      sleep=lambda dt: t.__setitem__(0, t[0] + dt))
        drive.configure(400.0, 1.0, 0.0)
        drive.on()
        del links.log[:]
        drive.ramp(3.0)          # 2 Vpp at 10 Vpp/s in 50 ms steps of 0.5 Vpp: 4 steps
        writes = [c for k, c in links.log if k == "w"]
        assert len(writes) == 4
        assert all(":AMPLitude " in c for c in writes)
        assert gen.read_settings().amplitude_vpp == 3.0
    finally:
        gen.close()


# ---- item 5: the amplitude unit is pinned to Vpp -------------------------------------
def test_a_front_panel_in_vrms_cannot_break_the_read_back(lib, links):
    peek(lib, "SOURce1:VOLTage:UNIT VRMS", write=True)   # someone pressed Units on the panel
    links.cfg.quirks = {"vrms_readback": True}
    with AFG1022(RES, lib, timeout_ms=500) as gen:
        s = gen.apply(400.0, 2.0)
        assert s.amplitude_vpp == 2.0
    assert peek(lib, "SOURce1:VOLTage:UNIT?") == "VPP"


# ---- item 6: OFF is both outputs OFF, on every path --------------------------------------
@pytest.mark.parametrize("path", ["set_output", "close", "failure"])
def test_off_switches_both_channels_off(lib, path, monkeypatch):
    ch2 = AFG1022.open(RES, lib, channel=2, timeout_ms=500)
    ch2.apply(400.0, 2.0)
    ch2.set_output(True)      # the antiphase drive on CH2
    ch2.release()
    gen = AFG1022.open(RES, lib, timeout_ms=500)
    gen.apply(400.0, 2.0)
    gen.set_output(True)
    assert peek(lib, "OUTPut2:STATe?") == "ON"
    if path == "set_output":
        gen.set_output(False)
    elif path == "close":
        gen.close()
    else:
        def dead(cmd):
            raise pyvisa.errors.VisaIOError(pyvisa.constants.StatusCode.error_connection_lost)
        monkeypatch.setattr(gen._res, "query", dead)
        with pytest.raises(HardwareError, match="output switched OFF"):
            gen.read_settings()
    assert (peek(lib, "OUTPut1:STATe?"), peek(lib, "OUTPut2:STATe?")) == ("OFF", "OFF")
    gen.close()


def test_the_service_stop_hook_switches_both_channels_off(lib, tmp_path):
    from labjoint.cli.daemon_glue import output_off

    for ch in (1, 2):
        g = AFG1022.open(RES, lib, channel=ch, timeout_ms=500)
        g.apply(400.0, 2.0)
        g.set_output(True)
        g.release()
    cfg = tmp_path / "rig.toml"
    text = (CONFIG_DIR / "rig-real.toml").read_text()
    text = text.replace('resource = "USB0::0x0699::0x0353::EDIT_SERIAL::INSTR"', f'resource = "{RES}"')
    cfg.write_text(text.replace('visa_library = ""', f'visa_library = "{lib}"'))
    assert load_config(cfg).rig.backend == "real"
    answer = output_off(cfg)
    assert answer["output"] is False
    assert (peek(lib, "OUTPut1:STATe?"), peek(lib, "OUTPut2:STATe?")) == ("OFF", "OFF")


# ---- item 7: a stale session is reopened before the next command ------------------------
def test_after_a_dead_link_the_next_command_uses_a_fresh_session(lib):
    gen = AFG1022.open(RES, lib, timeout_ms=500)
    try:
        gen.apply(400.0, 5.0)
        gen._res.close()  # the USB link died under the driver: the session is stale
        with pytest.raises(HardwareError):
            gen.apply(400.0, 6.0)
        s = gen.apply(400.0, 6.0)  # reopened, not "invalid session" forever
        assert s.amplitude_vpp == 6.0 and gen.connected
    finally:
        gen.close()
