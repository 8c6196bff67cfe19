"""A run name is never silently reused: storage, the catalog and plan admission refuse."""

import pytest

from labjoint.acquisition import plans
from labjoint.acquisition.admission import check_plan
from labjoint.acquisition.messages import Configure, Record
from labjoint.config import load_config
from labjoint.errors import InputError
from labjoint.storage.catalog import Catalog
from labjoint.storage.csv_import import import_csv

CSV = "# frequency_hz: 100\ntime_s,displacement_m,force_N\n" + "".join(
    f"{i / 1000!r},{1e-6 * (i % 7)!r},{0.5 * (i % 5)!r}\n" for i in range(200))


def test_a_catalog_shared_by_two_directories_never_replaces_a_run_by_name(tmp_path):
    (tmp_path / "r1.csv").write_text(CSV)
    cat = Catalog(tmp_path / "shared.sqlite")
    first = import_csv(tmp_path / "r1.csv", tmp_path / "a", catalog=cat)
    with pytest.raises(InputError, match="already holds a run named 'r1'"):
        import_csv(tmp_path / "r1.csv", tmp_path / "b", catalog=cat)
    assert not (tmp_path / "b").exists() or not list((tmp_path / "b").glob("*.h5"))
    assert cat.get("r1").path == str(first.resolve())
    cat.add(first)                                        # re-indexing the same file is fine
    assert len(cat.query()) == 1
    second = import_csv(tmp_path / "r1.csv", tmp_path / "b", name="r1_b", catalog=cat)
    assert {r.name for r in cat.query()} == {"r1", "r1_b"} and second.exists()


def test_a_plan_that_would_make_two_runs_of_one_name_is_refused_at_submit(monkeypatch):
    def twice(frequency_hz: float = 100.0):
        yield Configure(frequency_hz, 1.0)
        yield Record("same", n_cycles=10)
        yield Record("same", n_cycles=10)

    monkeypatch.setitem(plans.PLANS, "twice", twice)
    with pytest.raises(InputError, match="'same' was already made by step 2"):
        check_plan({"plan": "twice"}, load_config(None))
    check_plan({"plan": "amplitude_sweep", "amplitudes_vpp": [1.0, 1.0]}, load_config(None))
