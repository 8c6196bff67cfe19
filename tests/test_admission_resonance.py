"""The admission check (issue 33 item 18) dry-ran every plan against an ideal rig that
measured one channel, 'reference': every phase_resonance plan was refused ("channels
'free_end' and 'reference' must be measured (have reference)"), the README's own
`labjoint simulate --plan pr.toml` included. The ideal rig now answers on the config's
channels, in quadrature, so the plan's records are checked as well."""

from __future__ import annotations

from pathlib import Path

import pytest

from labjoint.acquisition.admission import check_plan
from labjoint.config import load_config
from labjoint.errors import InputError

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "rig-structure-sim.toml"
README_PLAN = {"plan": "phase_resonance", "levels_vpp": [0.5, 1.5, 5.0], "f_start_hz": 28.0,
               "band_hz": [20.0, 35.0], "response_channel": "free_end", "n_cycles": 60,
               "ringdown_s": 8.0}


@pytest.fixture(scope="module")
def config():
    return load_config(CONFIG)


@pytest.mark.parametrize("quantity", ["acceleration", "velocity", "displacement"])
def test_the_readme_phase_resonance_plan_is_admitted(config, quantity):
    check_plan({**README_PLAN, "response_quantity": quantity}, config)


@pytest.mark.parametrize("change, field", [({"n_cycles": 10**12}, "n_cycles"),
                                           ({"ringdown_s": 1e12}, "duration_s"),
                                           ({"levels_vpp": [0.5, 1e6]}, "amplitude_vpp")])
def test_its_records_and_levels_are_checked_against_the_rig(config, change, field):
    with pytest.raises(InputError) as e:
        check_plan({**README_PLAN, **change}, config)
    assert e.value.field == field


def test_a_response_channel_the_rig_does_not_have_is_named(config):
    with pytest.raises(InputError, match="'nope'") as e:
        check_plan({**README_PLAN, "response_channel": "nope"}, config)
    assert e.value.field == "response_channel" and "free_end" in str(e.value)
