"""Stick-slip pipeline on runs of the simulated rig (tests may use the simulator).

Also the helpers the friction and calibration tests share: simulate a steady run and
write it as a run file through the storage writer, as acquisition would.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from labjoint.documents import Block, RunStart, RunStop
from labjoint.config import load_config
from labjoint.hardware.interfaces import GeneratorSettings
from labjoint.hardware.sim.config import SimConfig
from labjoint.hardware.sim.rig import SimRig
from labjoint.storage import RunWriter, read_run

RATIO = 478.0


def simulate(frequency_hz: float, vpp: float, torque_nm: float, seconds: float = 0.4,
             settle_s: float = 0.4, sim: dict | None = None):
    """Volts (n_channels, n), channel specs, fs and the rig after a steady record."""
    cfg = load_config()
    table = dict(cfg.sim)
    table.update(sim or {})
    table["contact"] = {**table.get("contact", {}), "torque_nm": torque_nm}
    sc = SimConfig.from_rig(cfg.model_copy(update={"sim": table}))
    specs = cfg.daq.specs()
    fs = cfg.daq.sample_rate_hz
    rig = SimRig(sc, specs, fs)
    on = GeneratorSettings(frequency_hz, vpp, 0.0, True)
    rig.advance(int(settle_s * fs), on)
    return rig.advance(int(seconds * fs), on), specs, rig.sample_rate_hz, rig


def write_sim_run(data_dir: Path, name: str, frequency_hz: float, vpp: float,
                  torque_nm: float, **kw) -> Path:
    """A steady simulated run written as a run file (metadata as the engine writes it)."""
    volts, specs, fs, _rig = simulate(frequency_hz, vpp, torque_nm, **kw)
    md = {"frequency_hz": frequency_hz, "excitation_vpp": vpp, "torque_nm": torque_nm,
          "normal_force_n": torque_nm * RATIO, "sample_rate_hz": fs,
          "joint_force_channel": "shear_nc", "reference_force_channel": "force_ref",
          "displacement_channels": ["disp_1", "disp_2"]}
    uid = f"uid-{name}"
    with RunWriter(data_dir) as w:
        w("start", RunStart(uid, name, specs, fs, md))
        for a in range(0, volts.shape[1], 25000):
            w("block", Block(uid, a, volts[:, a:a + 25000]))
        w("stop", RunStop(uid, "complete", n_samples=volts.shape[1]))
    return data_dir / f"{name}.h5"


# ---- tests ------------------------------------------------------------------------------

from labjoint.hardware.sim.config import SimConfig as _SimConfig  # noqa: E402
from labjoint.identify.friction import identify_friction  # noqa: E402
from labjoint.identify.identified import Identified, save_identified  # noqa: E402
from labjoint.identify.methods import analyze_runs, format_table  # noqa: E402
from labjoint.storage import read_processed  # noqa: E402

MU_SIM = _SimConfig().contact.friction_coefficient
#: seed 002 Table 3: the loop damping is ~1730-1870 Ns/m at every amplitude (W ~ U^2),
#: an amplitude-independent loss the ring-Iwan contact alone does not have (W ~ U^3);
#: the default simulated joint (``seed002``: rings in series with a viscoelastic layer) has it.
SEED_LIKE_JOINT: dict = {}
DRY = {"joint": "dry_microslip"}
SWEEP_VPP = (1.0, 4.0, 8.0, 12.0, 16.0, 20.0)


def _mu() -> Identified:
    return Identified("friction_coefficient", MU_SIM, 0.0, "1", "simulator truth", "test")


def test_methods_agree_within_20_percent_over_the_amplitude_sweep(tmp_path):
    # inputs identified, not typed in: mu from a friction test (100 Hz, 2 Nm, macro-slip;
    # the plain contact, whose mu is the same), kept in the data directory; K_t per run
    fric = write_sim_run(tmp_path, "friction", 100.0, 20.0, 2.0, seconds=0.2)
    save_identified(tmp_path, identify_friction(read_run(fric)))
    paths = [write_sim_run(tmp_path, f"a{v:g}", 400.0, v, 5.0, seconds=0.2,
                           sim=SEED_LIKE_JOINT) for v in SWEEP_VPP]
    rows = analyze_runs(paths, "both", data_dir=tmp_path)
    assert all(r["friction_source"] == "friction" for r in rows)
    assert all(r["shear_stiffness_source"] == r["run"] for r in rows)
    diffs = np.array([r["energy_loss_diff_pct"] for r in rows])
    assert np.all(np.abs(diffs) < 20.0), diffs
    # Eq. 6 cancels c_i: the stick-slip damping is exactly 2 K_t / (pi omega) = K / (pi omega)
    # at every amplitude -- a model value fixed by the loop slope, not a second measurement
    c_ss = np.array([r["stickslip_damping_ns_per_m"] for r in rows])
    k = np.array([r["stickslip_stiffness_n_per_m"] for r in rows])
    assert np.allclose(c_ss, k / (np.pi * 2 * np.pi * 400.0), rtol=2e-3)
    # both methods see the same amplitude; energy grows with it
    u = np.array([r["displacement_amplitude_m"] for r in rows])
    assert np.allclose(u, [r["stickslip_displacement_amplitude_m"] for r in rows], rtol=0.01)
    assert np.all(np.diff([r["stickslip_energy_loss_j"] for r in rows]) > 0)
    table = format_table(rows)
    assert "W loop mJ" in table and len(table.splitlines()) == 2 + len(rows)


def test_pure_microslip_contact_cannot_match_the_stickslip_energy(tmp_path):
    """The dry contact alone (ring Iwan, no linear loss): the loop's loss factor grows
    with amplitude (micro-slip, W ~ U^3) while the stick-slip method's stays 1/pi."""
    paths = [write_sim_run(tmp_path, f"m{v:g}", 400.0, v, 5.0, seconds=0.15, sim=DRY)
             for v in (4.0, 20.0)]
    rows = analyze_runs(paths, "both", friction=_mu())
    eta_loop = [r["energy_loss_j"] / (np.pi * r["stiffness_n_per_m"] * r["displacement_amplitude_m"] ** 2)
                for r in rows]
    eta_ss = [r["stickslip_energy_loss_j"] / (np.pi * r["stickslip_stiffness_n_per_m"]
                                              * r["stickslip_displacement_amplitude_m"] ** 2)
              for r in rows]
    assert eta_loop[1] > 5 * eta_loop[0]
    assert np.allclose(eta_ss, 1 / np.pi, rtol=2e-3)
    assert all(r["energy_loss_diff_pct"] < -100 for r in rows)   # stick-slip >> loop


def test_curves_are_stored_in_the_run_file(tmp_path):
    path = write_sim_run(tmp_path, "ref", 400.0, 20.0, 5.0, seconds=0.1, sim=SEED_LIKE_JOINT)
    analyze_runs([path], "stickslip", friction=_mu(), store=True)
    arrays, attrs = read_processed(path, "stickslip")
    c, w, cd = arrays["boundary_radius"], arrays["energy_loss"], arrays["damping"]
    u = arrays["displacement"]
    assert u[0] == 0 and cd[0] == 0 and w[0] == 0
    rising = np.diff(u) > 0
    assert np.all(np.diff(c)[rising] < 0)                       # c(u) falls as u grows
    assert np.all(w >= 0)
    assert 0 < c.min() < c.max() <= 3.5 * 5e-3
    assert json.loads(attrs["friction_coefficient"])["source"] == "simulator truth"
    assert json.loads(attrs["shear_stiffness"])["source"] == "ref"   # K_t from this run's loop
    assert json.loads(attrs["summary"])["energy_loss_j"] > 0
    assert not arrays["macro_slip"].any()


def test_stickslip_rows_carry_provenance_and_no_loop_fields(tmp_path):
    path = write_sim_run(tmp_path, "only", 400.0, 8.0, 5.0, seconds=0.1, sim=SEED_LIKE_JOINT)
    (row,) = analyze_runs([path], "stickslip", friction=_mu())
    assert row["method"] == "stickslip" and "energy_loss_j" not in row
    assert row["shear_stiffness_uncertainty_n_per_m"] > 0
    assert row["stickslip_cycles"] > 10
    with pytest.raises(Exception) as exc:
        analyze_runs([path], "stickslip")                        # no friction coefficient
    assert "friction" in str(exc.value)
