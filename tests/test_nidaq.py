"""NIDAQ against autospecs of nidaqmx's own classes: calls, arguments and their order.

The NI-DAQmx C library is absent here, so nidaqmx.Task and the stream reader are
replaced by ``create_autospec`` mocks of the real classes (wrong argument names or
methods fail as they would on the real API). One log (``rig.log``) records every call
and property write in order.
"""

import subprocess
import sys
from dataclasses import replace
from unittest import mock

import numpy as np
import pytest
from nidaqmx.constants import (AcquisitionType, Coupling, ExcitationSource, OverwriteMode,
                               TaskMode, VoltageUnits)
from nidaqmx.error_codes import DAQmxErrors
from nidaqmx.errors import DaqError, DaqReadError
from nidaqmx.task import Task
from nidaqmx.task._in_stream import InStream
from nidaqmx.task._timing import Timing
from nidaqmx.task.channels import AIChannel
from nidaqmx.task.collections._ai_channel_collection import AIChannelCollection

from labjoint.config import load_config
from labjoint.errors import BufferOverrun, ConfigError, HardwareError, InputError, InstrumentTimeout
from labjoint.hardware.interfaces import ChannelSpec
from labjoint.hardware.nidaq import NIDAQ, offered_rate

# rig-sim's channels (force_ref ai0, disp_1 ai1, disp_2 ai2, shear_nc ai3), all IEPE: an NI
# 9233 excites every input, so it takes IEPE sensors only (tests/test_nidaq_bench.py)
SPECS = [replace(s, iepe=True) for s in load_config().daq.specs()]


class Rig:
    """Autospecced task + reader; hardware honours the requested rate unless told."""

    def __init__(self):
        self.log = mock.Mock()
        self.task = mock.create_autospec(Task, instance=True)
        self.task.ai_channels = mock.create_autospec(AIChannelCollection, instance=True)
        self.task.timing = mock.create_autospec(Timing, instance=True)
        self.task.in_stream = mock.create_autospec(InStream, instance=True)
        self.log.attach_mock(self.task, "task")
        self.reported_rate = None
        self._prop(self.task.in_stream, "input_buf_size")
        self._prop(self.task.in_stream, "overwrite")
        rate = self._prop(self.task.timing, "samp_clk_rate")
        rate.side_effect = lambda: (self.reported_rate if self.reported_rate is not None
                                    else self.task.timing.cfg_samp_clk_timing.call_args.args[0])
        self.channels = []
        self.task.ai_channels.add_ai_voltage_chan.side_effect = self._new_channel

    def _prop(self, obj, name, prefix=""):
        pm = mock.PropertyMock()
        setattr(type(obj), name, pm)
        self.log.attach_mock(pm, prefix + name)
        return pm

    def _new_channel(self, physical_channel, **kw):
        chan = mock.create_autospec(AIChannel, instance=True)
        for p in ("ai_coupling", "ai_excit_src", "ai_excit_val"):
            self._prop(chan, p, prefix=f"{kw['name_to_assign_to_channel']}.")
        self.channels.append(chan)
        return chan


@pytest.fixture
def rig():
    r = Rig()
    with mock.patch("nidaqmx.Task", autospec=True) as task_cls, \
         mock.patch("nidaqmx.stream_readers.AnalogMultiChannelReader", autospec=True) as reader_cls:
        task_cls.return_value = r.task
        r.log.attach_mock(task_cls, "Task")
        r.log.attach_mock(reader_cls, "Reader")
        r.reader = reader_cls.return_value
        r.counter = 0

        def fill(data, number_of_samples_per_channel, timeout):
            n = number_of_samples_per_channel
            data[:, :n] = r.counter + np.arange(n) + 1000.0 * np.arange(data.shape[0])[:, None]
            r.counter += n
            return n

        r.reader.read_many_sample.side_effect = fill
        yield r


def name(c):
    return c[0]


def test_configure_adds_channels_coupling_iepe_then_timing_then_buffer(rig):
    daq = NIDAQ("cDAQ1Mod1", "NI 9233", buffer_s=2.0)
    assert daq.configure(SPECS, 50000.0) == 50000.0
    daq.start()
    C = mock.call
    expected = [C.Task()]
    for spec in SPECS:
        expected.append(C.task.ai_channels.add_ai_voltage_chan(
            f"cDAQ1Mod1/{spec.physical_channel}", name_to_assign_to_channel=spec.name,
            min_val=-spec.range_v, max_val=spec.range_v, units=VoltageUnits.VOLTS))
        expected.append(getattr(C, f"{spec.name}.ai_coupling")(Coupling.AC))
        if spec.iepe:
            expected.append(getattr(C, f"{spec.name}.ai_excit_src")(ExcitationSource.INTERNAL))
            expected.append(getattr(C, f"{spec.name}.ai_excit_val")(0.002))
    expected += [
        C.task.timing.cfg_samp_clk_timing(50000.0, sample_mode=AcquisitionType.CONTINUOUS,
                                          samps_per_chan=100000),
        C.input_buf_size(100000),
        C.overwrite(OverwriteMode.DO_NOT_OVERWRITE_UNREAD_SAMPLES),
        C.task.control(TaskMode.TASK_COMMIT),
        C.samp_clk_rate(),
        C.Reader(rig.task.in_stream),
        C.task.start(),
    ]
    assert rig.log.mock_calls == expected
    assert daq.channels == SPECS


@pytest.mark.parametrize("requested, n", [(7000.0, 7), (2000.0, 25), (25000.0, 2), (24999.0, 2)])
def test_rate_snaps_to_the_9233_offer_50k_over_n(rig, requested, n):
    daq = NIDAQ()
    actual = daq.configure(SPECS, requested)
    assert actual == pytest.approx(50000.0 / n, rel=1e-12) and actual >= requested
    assert rig.task.timing.cfg_samp_clk_timing.call_args.args[0] == pytest.approx(50000.0 / n)
    assert daq.sample_rate_hz == actual


def test_rate_reported_by_the_hardware_wins(rig, caplog):
    rig.reported_rate = 25000.0
    assert NIDAQ().configure(SPECS, 50000.0) == 25000.0
    assert "module runs at 25000" in caplog.text


@pytest.mark.parametrize("module, rate", [("NI 9233", 60000.0), ("NI 9233", 1000.0), ("NI 9233", 0.0),
                                          ("NI 9215", 2e5)])
def test_rate_beyond_the_module_is_refused_before_any_task(rig, module, rate):
    specs = SPECS if module == "NI 9233" else [replace(s, coupling="DC", iepe=False) for s in SPECS]
    with pytest.raises(InputError) as info:
        NIDAQ(module=module).configure(specs, rate)
    assert info.value.field == "daq.sample_rate_hz"
    assert rig.log.mock_calls == []


def test_dc_coupling_refused_on_the_ac_only_9233(rig):
    specs = [SPECS[0], replace(SPECS[1], coupling="DC")]
    with pytest.raises(ConfigError, match="NI 9233 is AC-coupled only") as info:
        NIDAQ(module="NI 9233").configure(specs, 50000.0)
    assert info.value.field == "daq.channels.disp_1.coupling"
    assert rig.log.mock_calls == []


def test_dc_coupled_module_configures_dc_without_excitation(rig):
    specs = [replace(s, coupling="DC", iepe=False, range_v=10.0) for s in SPECS[1:3]]
    assert NIDAQ("cDAQ1Mod2", "NI 9239").configure(specs, 50000.0) == 50000.0
    calls = rig.log.mock_calls
    assert mock.call.task.ai_channels.add_ai_voltage_chan(
        "cDAQ1Mod2/ai1", name_to_assign_to_channel="disp_1", min_val=-10.0, max_val=10.0,
        units=VoltageUnits.VOLTS) in calls
    assert getattr(mock.call, "disp_2.ai_coupling")(Coupling.DC) in calls
    assert not any("excit" in name(c) for c in calls)


@pytest.mark.parametrize("module, change, field", [
    ("NI 9239", dict(coupling="DC"), "daq.channels.force_ref.iepe"),      # no IEPE on a 9239
    ("NI 9233", dict(range_v=10.0), "daq.channels.force_ref.range_v"),    # 9233 is +-5 V
    ("NI 9234", dict(coupling="DC"), "daq.channels.force_ref.coupling"),  # IEPE needs AC
])
def test_channels_the_module_cannot_measure_are_refused(rig, module, change, field):
    with pytest.raises(ConfigError) as info:
        NIDAQ(module=module).configure([replace(SPECS[0], **change)], 10000.0)
    assert info.value.field == field


def test_unknown_module_and_shared_inputs_refused(rig):
    with pytest.raises(ConfigError, match="unknown DAQ module"):
        NIDAQ(module="NI 6001").configure(SPECS, 1000.0)
    with pytest.raises(ConfigError, match="share ai1"):
        NIDAQ().configure([SPECS[1], replace(SPECS[2], physical_channel="ai1")], 50000.0)


def test_reads_into_the_preallocated_buffer_with_the_requested_count(rig):
    daq = NIDAQ(read_timeout_s=3.0)
    daq.configure(SPECS, 50000.0)
    daq.start()
    out = np.zeros((4, 500))
    got = daq.read(500, out)
    assert got is out
    args, kwargs = rig.reader.read_many_sample.call_args
    assert args[0] is out and kwargs == {"number_of_samples_per_channel": 500, "timeout": 3.0}
    assert daq.samples_read == 500
    second = daq.read(500)  # allocates (n_channels, n) float64 when no buffer is given
    assert second.shape == (4, 500) and second.dtype == np.float64
    assert daq.samples_read == 1000
    # rows are channels in configuration order, columns consecutive samples
    np.testing.assert_array_equal(second[2, :3], [2500.0, 2501.0, 2502.0])


@pytest.mark.parametrize("bad", [np.zeros((4, 500), np.float32), np.zeros((3, 500)),
                                 np.zeros((500, 4)).T])
def test_unusable_buffers_are_refused(rig, bad):
    daq = NIDAQ()
    daq.configure(SPECS, 50000.0)
    daq.start()
    with pytest.raises(InputError) as info:
        daq.read(500, bad)
    assert info.value.field == "out"
    rig.reader.read_many_sample.assert_not_called()


@pytest.mark.parametrize("error", [DAQmxErrors.SAMPLES_NO_LONGER_AVAILABLE,
                                   DAQmxErrors.INPUT_FIFO_OVERFLOW,
                                   DAQmxErrors.ACQ_STOPPED_TO_PREVENT_INPUT_BUFFER_OVERWRITE])
def test_overrun_raises_buffer_overrun_keeping_the_counter_and_data(rig, error):
    daq = NIDAQ()
    daq.configure(SPECS, 50000.0)
    daq.start()
    first = daq.read(500).copy()
    rig.reader.read_many_sample.side_effect = DaqReadError(
        "Attempted to read samples that are no longer available.", error.value, 0)
    with pytest.raises(BufferOverrun, match="samples lost") as info:
        daq.read(500)
    assert info.value.samples_read == 500 and info.value.error_code == error.value
    assert daq.samples_read == 500
    np.testing.assert_array_equal(first[0, :2], [0.0, 1.0])


def test_read_timeout_and_other_errors_are_not_overruns(rig):
    daq = NIDAQ()
    daq.configure(SPECS, 50000.0)
    daq.start()
    rig.reader.read_many_sample.side_effect = DaqReadError(
        "timeout", DAQmxErrors.SAMPLES_NOT_YET_AVAILABLE.value, 12)
    with pytest.raises(InstrumentTimeout) as info:
        daq.read(100)
    assert info.value.partial_samples == 12
    rig.reader.read_many_sample.side_effect = DaqError("device removed",
                                                       DAQmxErrors.DEVICE_REMOVED.value)
    with pytest.raises(HardwareError) as info:
        daq.read(100)
    assert not isinstance(info.value, (BufferOverrun, InstrumentTimeout))


def test_read_before_start_is_refused(rig):
    daq = NIDAQ()
    daq.configure(SPECS, 50000.0)
    with pytest.raises(HardwareError, match="before start"):
        daq.read(10)


def test_close_stops_then_closes_and_is_idempotent(rig):
    daq = NIDAQ()
    daq.configure(SPECS, 50000.0)
    daq.start()
    daq.stop()
    daq.stop()
    daq.close()
    daq.close()
    tail = [c for c in rig.log.mock_calls if name(c) in ("task.start", "task.stop", "task.close")]
    assert tail == [mock.call.task.start(), mock.call.task.stop(), mock.call.task.close()]


def test_close_after_a_dead_device_never_raises(rig, caplog):
    daq = NIDAQ()
    daq.configure(SPECS, 50000.0)
    daq.start()
    rig.task.stop.side_effect = DaqError("device removed", DAQmxErrors.DEVICE_REMOVED.value)
    daq.close()
    assert [name(c) for c in rig.log.mock_calls[-2:]] == ["task.stop", "task.close"]
    assert "lost (DAQmx -200045)" in caplog.text


def test_reconfigure_closes_the_previous_task(rig):
    daq = NIDAQ()
    daq.configure(SPECS, 50000.0)
    daq.configure(SPECS[:2], 10000.0)
    assert rig.task.close.call_count == 1
    assert daq.channels == SPECS[:2] and daq.sample_rate_hz == 10000.0


def test_without_the_ni_driver_configure_says_so():
    daq = NIDAQ()
    with pytest.raises(HardwareError, match="NI-DAQmx driver not installed"):
        daq.configure(SPECS, 50000.0)


def test_module_imports_without_touching_nidaqmx():
    code = "import sys, labjoint.hardware.nidaq; assert 'nidaqmx' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_channelspec_default_physical_channels_follow_row_order(rig):
    specs = [ChannelSpec("a", "voltage", "voltage", "V", 1.0, coupling="DC"),
             ChannelSpec("b", "voltage", "voltage", "V", 1.0, coupling="DC")]
    NIDAQ("Mod3", "NI 9239").configure(specs, 50000.0)
    added = [c.args[0] for c in rig.task.ai_channels.add_ai_voltage_chan.call_args_list]
    assert added == ["Mod3/ai0", "Mod3/ai1"]
    assert offered_rate("NI 9215", 12345.0) == 12345.0  # SAR module: any rate up to its max
