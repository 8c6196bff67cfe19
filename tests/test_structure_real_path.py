"""step_sine on the real rig's code path for a structural rig (issue 15 item 5): the AFG1022
driver on pyvisa-sim and the NI DAQ driver on an autospecced nidaqmx (no hardware), whose
reader returns what a linear structure would give for the generator's current settings."""

import numpy as np
import pytest

from labjoint.acquisition.engine import RunEngine
from labjoint.acquisition.plans import step_sine
from labjoint.acquisition.rig import open_rig
from labjoint.config import CONFIG_DIR, load_config
from labjoint.signal.frf_steps import frfset_from_runs
from labjoint.storage.writer import RunWriter
from test_daemon_fixtures import FakeClock
from test_nidaq import rig  # noqa: F401  (the autospec fixture)

FN = 28.5


def force_per_volt(f):
    """N per generator volt: the shaker cannot push at the structure's resonance."""
    return 4.0 * (1 - 0.6 * np.exp(-((f - FN) / 0.6) ** 2))


def accelerance(f, scale):
    w, wn = 2 * np.pi * f, 2 * np.pi * FN
    return scale * -(w**2) / (wn**2 - w**2 + 2j * 0.01 * wn * w)


def test_step_sine_holds_the_force_through_the_real_drivers(rig, tmp_path):  # noqa: F811
    cfg = load_config(CONFIG_DIR / "rig-structure-sim.toml", {"rig": {"backend": "real"}})
    lab = open_rig(cfg)
    assert lab.sim is None and type(lab.daq).__name__ == "NIDAQ"
    specs = cfg.daq.specs()
    fs = cfg.daq.sample_rate_hz
    scales = {"coupling_short_side": 0.2, "coupling_long_side": 0.25, "free_end": 1.0}

    def fill(data, number_of_samples_per_channel, timeout):
        n = number_of_samples_per_channel
        s = lab.generator.read_settings()
        t = (rig.counter + np.arange(n)) / fs
        e = np.exp(2j * np.pi * s.frequency_hz * t)
        v = (0.5 * s.amplitude_vpp if s.output else 0.0) * e
        f = force_per_volt(s.frequency_hz) * v
        for i, spec in enumerate(specs):
            x = {"force": f, "drive": v}.get(spec.name)
            x = f * accelerance(s.frequency_hz, scales[spec.name]) if x is None else x
            data[i, :n] = (x.imag / spec.sensitivity)
        rig.counter += n
        return n

    rig.reader.read_many_sample.side_effect = fill
    c = FakeClock()
    eng = RunEngine(lab.generator, lab.daq, cfg.limits, [RunWriter(tmp_path)], clock=c, sleep=c.sleep,
                    config=cfg)
    r = eng.run(step_sine([27.0, 28.5, 30.0], 5.0, n_cycles=16, measure_cycles=8, directions=["up"]),
                name_prefix="real")
    lab.close()
    assert r.status == "complete", r.reason
    assert len(r.runs) == 3
    s = frfset_from_runs(sorted(tmp_path.glob("*.h5")), harmonics=2, segments=4)
    assert np.abs(s.force) == pytest.approx(5.0, rel=0.03) and not s.metadata["unconverged"]
    assert s.accelerance()[:, 2] == pytest.approx(accelerance(s.frequencies_hz, 1.0), rel=1e-3)
    assert np.abs(s.response[:, :, 1]).max() < 1e-3 * np.abs(s.response[:, :, 0]).max()   # no harmonics
    vpp = 2 * np.abs(s.drive_v)
    assert vpp[1] > 2 * min(vpp[0], vpp[2])      # the loop raised the drive where the force dips
    assert vpp == pytest.approx(10.0 / force_per_volt(s.frequencies_hz), rel=0.03)
