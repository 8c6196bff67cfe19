"""`labjoint structure modes|update|frf --json` on the seed 000 assembly."""

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SEED000 = str(ROOT / "configs" / "structure-seed000.toml")


def cli(*args):
    exe = Path(sys.executable).with_name("labjoint")
    return subprocess.run([str(exe), "structure", *args], capture_output=True, text=True, cwd=ROOT)


def test_modes_update_and_frf_print_one_json_object():
    m = json.loads(cli("modes", SEED000, "--json").stdout)
    # the file ships the joint updated to seed 000's 28.5 / 177 Hz (issue 32)
    assert abs(m["frequencies_hz"][0] - 28.5) < 0.05 and m["frequencies_hz"] == sorted(m["frequencies_hz"])
    u = json.loads(cli("update", SEED000, "--measured-hz", "28.5,177", "--set", "E_e_pa=215e9",
                       "--json").stdout)
    assert set(u) >= {"parameters", "frequencies_hz", "history"}
    assert abs(u["frequencies_hz"][0] - 28.5) < 1.0 and len(u["history"]) >= 2
    e = u["parameters"]["E_e_pa"]["value"]
    # at 0.5 N the shipped law hardly yields (at 16.5 N RMS it softens mode 1 by 0.9 Hz)
    f = json.loads(cli("frf", SEED000, "--force-n", "0.5", "--band", "20:40", "--set", f"E_e_pa={e}",
                       "--json").stdout)
    acc = f["sensors"]["free_end"]["accelerance_m_s2_per_n"]
    peak = f["frequencies_hz"][acc.index(max(acc))]
    assert abs(peak - u["frequencies_hz"][0]) < 0.5        # the FRF peaks at the updated mode 1
    assert f["frequencies_hz"][0] == 20.0 and abs(f["frequencies_hz"][-1] - 40.0) < 1e-9


def test_bad_input_is_one_error_line_naming_the_problem():
    r = cli("frf", SEED000, "--force-n", "16.5", "--band", "40:20", "--json")
    assert r.returncode == 2 and r.stdout == "" and "band" in r.stderr
    r = cli("update", SEED000, "--measured-hz", "28.5,x", "--json")
    assert r.returncode == 2 and "--measured-hz" in r.stderr
