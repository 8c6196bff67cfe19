"""The FRF-set container: shapes checked, bad input names its field, JSON round trip."""

import json

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.signal.frfset import FrfSet


def _set(**kw):
    n = 4
    base = dict(frequencies_hz=[26.0, 27.0, 28.0, 27.0], level_n=[5.0, 5.0, 5.0, 16.5],
                direction=["up", "up", "down", "up"], force=np.full(n, 5.0 + 1.0j),
                sensors=("left", "tip"), response=np.arange(n * 2 * 3).reshape(n, 2, 3) * (1 + 2j) + 1,
                response_std=np.full((n, 2, 3), 0.1), drive_v=np.full(n, 2.0 + 0j),
                runs=("a", "b", "c", "d"))
    base.update(kw)
    return FrfSet(**base)


def test_accelerance_is_the_response_over_the_force_phasor():
    s = _set()
    assert np.allclose(s.accelerance(1), s.response[:, :, 0] / (5.0 + 1.0j))
    assert np.allclose(s.accelerance(3), s.response[:, :, 2] / (5.0 + 1.0j))


def test_groups_split_levels_and_directions_in_sweep_order():
    groups = dict(_set().groups())
    assert list(groups) == [(5.0, "up"), (5.0, "down"), (16.5, "up")]
    assert groups[(5.0, "up")].tolist() == [0, 1]


@pytest.mark.parametrize("key,value", [
    ("frequencies_hz", [1.0, -2.0, 3.0, 4.0]), ("level_n", [1.0, 1.0, 0.0, 1.0]),
    ("direction", ["up", "sideways", "up", "up"]), ("force", np.zeros(4)),
    ("sensors", ("tip", "tip")), ("response", np.ones((4, 1, 3))),
    ("response_std", -np.ones((4, 2, 3))), ("quantity", "strain"), ("runs", ("a",))])
def test_bad_input_names_the_field(key, value):
    with pytest.raises(InputError) as e:
        _set(**{key: value})
    assert e.value.field == key


def test_file_round_trip_and_subset(tmp_path):
    s = _set()
    p = s.save(tmp_path / "frf.json")
    back = FrfSet.load(p)
    assert back == s and back.runs == s.runs
    sub = back.subset(back.direction == "up")
    assert len(sub) == 3 and sub.runs == ("a", "b", "d")
    p.write_text(json.dumps({**s.to_dict(), "format": "other"}))
    with pytest.raises(InputError, match="format"):
        FrfSet.load(p)


@pytest.mark.parametrize("command", ["modes", "backbone"])
def test_a_bad_frf_file_is_one_line_naming_the_file(tmp_path, capsys, command):
    """`labjoint modes` and `labjoint backbone` on a broken FRF set: exit 2 and one line on
    stderr naming the file, whether the JSON, its format or one of its arrays is bad."""
    from labjoint.cli.main import main

    good = _set().to_dict()
    broken = {"not_json.json": "{\"format\": ", "format.json": json.dumps({"a": 1}),
              "array.json": json.dumps({**good, "level_n": good["level_n"][:2]}),
              "quantity.json": json.dumps({**good, "quantity": "banana"})}
    for name, text in broken.items():
        p = tmp_path / name
        p.write_text(text)
        assert main([command, str(p)]) == 2, name
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and str(p) in err[0], (name, err)
