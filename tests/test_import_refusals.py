"""Bad lab exports are refused in one line naming the file and the channel, exit 2, and
nothing (not even a temporary file) is left in --out."""

from __future__ import annotations

import h5py
import numpy as np
import pyuff
import scipy.io

import importgen as g
from labjoint.cli.main import main


def _refused(capsys, tmp_path, *argv, says: tuple[str, ...]):
    out = tmp_path / "data"
    assert main(["import", *map(str, argv), "--out", str(out), "--json"]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1, cap.err
    for s in says:
        assert s in lines[0], lines[0]
    assert not out.exists() or not list(out.iterdir())          # nothing half-written
    return lines[0]


def test_a_map_naming_a_missing_channel(tmp_path, capsys):
    src = g.write_csv(tmp_path / "r.csv")
    mp = g.write_map(tmp_path / "m.toml", acc="acc_z_g")
    _refused(capsys, tmp_path, src, "--map", mp, says=("r.csv", "'acc'", "acc_z_g"))


def test_a_unit_that_does_not_fit_its_quantity(tmp_path, capsys):
    src = g.write_csv(tmp_path / "r.csv")
    mp = g.write_map(tmp_path / "m.toml")
    mp.write_text(mp.read_text().replace('units = "mV"', 'units = "N"'))
    _refused(capsys, tmp_path, src, "--map", mp, says=("m.toml", "'drive'", "force, not a voltage"))


def test_a_quantity_the_map_does_not_state_is_never_guessed(tmp_path, capsys):
    src = g.write_csv(tmp_path / "r.csv")
    mp = g.write_map(tmp_path / "m.toml")
    mp.write_text(mp.read_text().replace('quantity = "velocity"\n', ""))
    _refused(capsys, tmp_path, src, "--map", mp, says=("m.toml", "'laser'", "quantity"))


def test_a_gapped_time_base(tmp_path, capsys):
    cols = g.lab_columns()
    cols = {k: np.delete(v, 300) for k, v in cols.items()}       # one sample lost
    src = g.write_csv(tmp_path / "gap.csv", cols)
    mp = g.write_map(tmp_path / "m.toml")
    _refused(capsys, tmp_path, src, "--map", mp, says=("gap.csv", "'time'", "gapped or non-uniform"))


def test_a_non_uniform_time_base(tmp_path, capsys):
    cols = g.lab_columns()
    cols["t"] = cols["t"] * (1 + 0.3 * (np.arange(g.N) / g.N) ** 2)   # slowly stretched clock
    src = g.write_csv(tmp_path / "drift.csv", cols)
    mp = g.write_map(tmp_path / "m.toml")
    _refused(capsys, tmp_path, src, "--map", mp, says=("drift.csv", "'time'", "non-uniform"))


def test_a_mat_file_with_ragged_channels(tmp_path, capsys):
    cols = g.lab_columns()
    cols["acc_g"] = cols["acc_g"][:-7]
    scipy.io.savemat(tmp_path / "ragged.mat", cols)
    mp = g.write_map(tmp_path / "m.toml")
    _refused(capsys, tmp_path, tmp_path / "ragged.mat", "--map", mp,
             says=("ragged.mat", "'acc'", "ragged"))


def test_an_unknown_uff_type(tmp_path, capsys):
    x = g.T.copy()
    good = pyuff.prepare_58(func_type=1, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, id1="u_mV",
                            data=np.sin(x), x=x, ord_data_type=4, abscissa_spacing=1,
                            abscissa_spec_data_type=17, ordinate_spec_data_type=0,
                            orddenom_spec_data_type=0, z_axis_spec_data_type=0, binary=0)
    pyuff.UFF(str(tmp_path / "odd.uff")).write_sets([good], mode="overwrite")
    with open(tmp_path / "odd.uff", "a") as fh:
        fh.write("    -1\n  2222\nsome dataset labjoint does not know\n    -1\n")
    mp = g.write_map(tmp_path / "m.toml")
    _refused(capsys, tmp_path, tmp_path / "odd.uff", "--map", mp,
             says=("odd.uff", "set 2", "type 2222"))


def test_a_uff_function_type_that_is_not_time_or_frf(tmp_path, capsys):
    x = np.linspace(0.0, 100.0, 64)
    spec = pyuff.prepare_58(func_type=2, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, id1="auto",
                            data=np.abs(np.sin(x)), x=x, ord_data_type=4, abscissa_spacing=1,
                            abscissa_spec_data_type=18, ordinate_spec_data_type=0,
                            orddenom_spec_data_type=0, z_axis_spec_data_type=0, binary=0)
    pyuff.UFF(str(tmp_path / "spec.uff")).write_sets([spec], mode="overwrite")
    mp = g.write_map(tmp_path / "m.toml")
    _refused(capsys, tmp_path, tmp_path / "spec.uff", "--map", mp,
             says=("spec.uff", "auto", "function type 2"))


def test_a_record_with_no_drive_channel(tmp_path, capsys):
    src = g.write_csv(tmp_path / "r.csv")
    mp = g.write_map(tmp_path / "m.toml")
    mp.write_text(mp.read_text().replace('role = "drive"', 'role = "other"'))
    _refused(capsys, tmp_path, src, "--map", mp, says=("r.csv", "m.toml", "no drive channel"))


def test_a_bad_second_file_leaves_nothing_of_the_first(tmp_path, capsys):
    good = g.write_csv(tmp_path / "a.csv")
    cols = g.lab_columns()
    cols["u_mV"][17] = np.nan
    bad = g.write_csv(tmp_path / "b.csv", cols)
    mp = g.write_map(tmp_path / "m.toml")
    _refused(capsys, tmp_path, good, bad, "--map", mp, says=("b.csv", "'drive'", "sample 17"))


def test_an_old_form_map_is_not_silently_ignored_for_a_csv(tmp_path, capsys):
    src = g.write_csv(tmp_path / "r.csv")
    (tmp_path / "old.toml").write_text('[channels.displacement_m]\ndataset = "y"\n'
                                       '[channels.force_N]\ndataset = "u"\n')
    _refused(capsys, tmp_path, src, "--map", tmp_path / "old.toml", says=("r.csv", "--map"))
    _refused(capsys, tmp_path, tmp_path / "x.mat", says=("x.mat", "--map"))


def test_two_tests_with_one_run_name(tmp_path, capsys):
    with h5py.File(tmp_path / "m.h5", "w") as f:
        for name in ("Sine 1", "Sine_1"):
            grp = f.create_group(name)
            for k, v in g.lab_columns().items():
                grp[k] = v
    mp = g.write_map(tmp_path / "m.toml", '[tests]\ninclude = ["Sine*"]\n')
    _refused(capsys, tmp_path, tmp_path / "m.h5", "--map", mp, says=("m.h5", "Sine_1"))
