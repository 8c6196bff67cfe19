"""AFG1022 driver end to end on its pyvisa-sim twin (configs/afg1022-sim.yaml)."""

import logging
import shutil

import pytest
import pyvisa
import pyvisa.constants
import pyvisa.errors

from labjoint.config import CONFIG_DIR, load_config
from labjoint.errors import HardwareError, InputError, InstrumentTimeout
from labjoint.hardware import afg1022
from labjoint.hardware.afg1022 import AFG1022, resolve_visa_library

RES = "USB0::0x0699::0x0353::SIM0001::INSTR"


@pytest.fixture
def lib(tmp_path):
    """A private copy of the instrument definition: pyvisa-sim keeps one instrument
    state per definition file and process, so each test gets a fresh instrument."""
    path = tmp_path / "afg1022-sim.yaml"
    shutil.copy(CONFIG_DIR / "afg1022-sim.yaml", path)
    return f"{path}@sim"


@pytest.fixture
def gen(lib):
    g = AFG1022.open(RES, lib, timeout_ms=200)
    yield g
    g.close()


def peek(lib, cmd):
    """Ask the simulated instrument through a second, independent VISA session."""
    r = pyvisa.ResourceManager(lib).open_resource(RES, read_termination="\n", write_termination="\n")
    try:
        return r.query(cmd).strip()
    finally:
        r.close()


def test_identify_names_the_model(gen):
    assert "AFG1022" in gen.identify()


def test_wrong_instrument_is_refused_naming_the_resource(tmp_path):
    text = (CONFIG_DIR / "afg1022-sim.yaml").read_text().replace("TEKTRONIX,AFG1022", "ACME,FG9000")
    path = tmp_path / "other.yaml"
    path.write_text(text)
    with pytest.raises(HardwareError, match="SIM0001.*not a Tektronix AFG1022"):
        AFG1022.open(RES, f"{path}@sim")


def test_rig_sim_config_opens_the_twin_by_relative_path():
    cfg = load_config()
    assert resolve_visa_library(cfg.generator.visa_library) == f"{CONFIG_DIR / 'afg1022-sim.yaml'}@sim"
    g = AFG1022.from_config(cfg.generator)
    try:
        assert "AFG1022" in g.identify()
    finally:
        g.release()


def test_apply_reads_back_what_was_set_twice_and_across_output_toggles(gen, lib):
    first = gen.apply(400.0, 20.0, 0.0)
    assert (first.frequency_hz, first.amplitude_vpp, first.offset_v) == (400.0, 20.0, 0.0)
    second = gen.apply(123.456789, 1.2345, -0.25)
    assert (second.frequency_hz, second.amplitude_vpp, second.offset_v) == (123.456789, 1.2345, -0.25)
    assert gen.read_settings() == second
    gen.set_output(True)
    on = gen.read_settings()
    assert on.output and on.frequency_hz == 123.456789 and on.amplitude_vpp == 1.2345
    gen.set_output(False)
    gen.set_output(True)
    assert gen.read_settings() == on
    # an independent session (what the simulated rig's instrument holds) agrees
    assert float(peek(lib, "SOURce1:FREQuency:FIXed?")) == 123.456789
    assert peek(lib, "SOURce1:VOLTage:UNIT?") == "VPP"
    assert peek(lib, "SOURce1:FUNCtion:SHAPe?").upper().startswith("SIN")


def test_channels_are_independent(lib):
    with AFG1022(RES, lib, channel=2) as g2:
        g2.apply(50.0, 2.0)
        g2.set_output(True)
    assert float(peek(lib, "SOURce2:FREQuency:FIXed?")) == 50.0
    assert float(peek(lib, "SOURce1:FREQuency:FIXed?")) != 50.0


def test_large_offset_then_large_amplitude_stays_in_window(gen):
    gen.apply(100.0, 2.0, 8.0)          # envelope 9 V
    s = gen.apply(100.0, 19.0, 0.25)    # must move the offset first
    assert (s.amplitude_vpp, s.offset_v) == (19.0, 0.25)


@pytest.mark.parametrize("args, field", [
    ((30e6, 1.0, 0.0), "frequency_hz"),
    ((0.0, 1.0, 0.0), "frequency_hz"),
    ((400.0, 21.0, 0.0), "amplitude_vpp"),
    ((400.0, 0.001, 0.0), "amplitude_vpp"),
    ((400.0, 10.0, 5.5), "offset_v"),
    ((float("nan"), 1.0, 0.0), "frequency_hz"),
])
def test_out_of_range_refused_before_talking_to_the_instrument(gen, args, field, monkeypatch):
    sent = []
    monkeypatch.setattr(gen._res, "write", sent.append)
    with pytest.raises(InputError) as info:
        gen.apply(*args)
    assert info.value.field == field
    assert sent == []


def test_instrument_rejection_surfaces_its_error(gen, monkeypatch):
    # Let a value past the instrument's range through the driver's own check:
    # the (simulated) instrument refuses it and says so in SYSTem:ERRor?.
    monkeypatch.setattr(afg1022, "MAX_FREQUENCY_HZ", 1e9)
    with pytest.raises(HardwareError, match="-200"):
        gen.apply(30e6, 1.0)


def test_readback_mismatch_is_an_error(gen, monkeypatch):
    real_query = gen._res.query

    def halved_amplitude(cmd):
        answer = real_query(cmd)
        return f"{float(answer) / 2:.12E}" if cmd.endswith("AMPLitude?") else answer

    monkeypatch.setattr(gen._res, "query", halved_amplitude)
    with pytest.raises(HardwareError, match="amplitude_vpp set to 4.0 but read back 2.0"):
        gen.apply(400.0, 4.0)


def test_timeout_gives_clear_error_and_switches_output_off(gen, lib, monkeypatch):
    gen.apply(400.0, 5.0)
    gen.set_output(True)
    assert peek(lib, "OUTPut1:STATe?") == "ON"

    def no_answer(cmd):
        raise pyvisa.errors.VisaIOError(pyvisa.constants.StatusCode.error_timeout)

    monkeypatch.setattr(gen._res, "query", no_answer)
    with pytest.raises(InstrumentTimeout, match=r"SIM0001.*'SOURce1:FREQuency:FIXed\?'.*output switched OFF"):
        gen.read_settings()
    assert peek(lib, "OUTPut1:STATe?") == "OFF"


def test_unknown_query_times_out_on_the_simulated_instrument(gen):
    with pytest.raises(InstrumentTimeout, match="no answer to 'SOURce1:BOGus\\?' within 200 ms"):
        gen._query("SOURce1:BOGus?")


def test_disconnect_gives_clear_error_and_close_never_raises(gen, caplog):
    gen.apply(400.0, 5.0)
    gen._res.close()  # the link dies under the driver (cable pulled)
    with caplog.at_level(logging.ERROR, logger="labjoint.hardware.afg1022"):
        with pytest.raises(HardwareError, match="SIM0001.*could not switch the output OFF"):
            gen.apply(400.0, 6.0)
        gen.close()
    assert "could not switch the output OFF" in caplog.text
    assert not gen.connected


def test_close_leaves_output_off_and_is_idempotent(lib):
    g = AFG1022.open(RES, lib)
    g.apply(400.0, 5.0)
    g.set_output(True)
    g.close()
    g.close()
    assert peek(lib, "OUTPut1:STATe?") == "OFF"
    with pytest.raises(HardwareError, match="not connected"):
        g.read_settings()


def test_bad_settings_are_input_errors(lib):
    with pytest.raises(InputError, match="channels 1 and 2"):
        AFG1022.open(RES, lib, channel=3)
    with pytest.raises(InputError) as info:
        AFG1022.open(RES, "missing.yaml@sim")
    assert info.value.field == "generator.visa_library"


def test_absent_resource_is_a_hardware_error(lib):
    with pytest.raises(HardwareError, match="cannot open USB0::0x0699::0x0353::NOPE::INSTR"):
        AFG1022.open("USB0::0x0699::0x0353::NOPE::INSTR", lib)


def test_config_folder_matches_the_config_layer():
    assert afg1022.CONFIG_DIR == CONFIG_DIR


def test_reads_from_another_thread_never_mix_answers(gen):
    # The simulated rig reads settings from its acquisition thread while plans apply new
    # ones: every read must be one complete state, never halves of two.
    import threading

    states = {(100.0, 1.0), (200.0, 2.0)}
    gen.apply(100.0, 1.0)
    seen, stop = [], threading.Event()

    def reader():
        while not stop.is_set():
            s = gen.read_settings()
            seen.append((s.frequency_hz, s.amplitude_vpp))

    t = threading.Thread(target=reader)
    t.start()
    try:
        for i in range(40):
            gen.apply(*((200.0, 2.0) if i % 2 == 0 else (100.0, 1.0)))
    finally:
        stop.set()
        t.join()
    assert seen and set(seen) <= states


def test_a_query_cut_short_by_ctrl_c_never_hands_its_answer_to_the_next(gen, lib):
    # Ctrl-C between a query's write and its read leaves the answer in the instrument's
    # output queue; the output OFF that follows must not read it as its own *OPC?.
    gen.apply(400.0, 5.0)
    gen.set_output(True)
    res = gen._res
    query = res.query

    def write_then_interrupt(cmd):
        res.query = query                      # once: a second would end pytest itself
        res.write(cmd)
        raise KeyboardInterrupt

    res.query = write_then_interrupt
    with pytest.raises(KeyboardInterrupt):
        gen._query("SOURce1:FREQuency:FIXed?")
    gen.set_output(False)                      # a fresh, cleared session: no HardwareError
    assert gen._res is not res
    assert peek(lib, "OUTPut1:STATe?") == "OFF"
    assert gen.read_settings().amplitude_vpp == pytest.approx(5.0)
