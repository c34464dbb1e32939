"""derive.scene.artifacts: what `derive all` and `derive run` derive, render and compile."""
import pytest

from derive.runtime.runner import library_path
from derive.scene.artifacts import prepare, prepare_c


@pytest.mark.slow     # derives, renders and compiles two models when the cache is cold
def test_prepare_c_compiles_side_by_side_what_prepare_compiles_one_by_one():
    names = ["planar", "compound"]
    steps = prepare_c(names, workers=2)
    assert [s.what for s in steps] == [s.what for name in names for s in prepare(name, "c")]
    assert [s.what for s in steps if s.what.startswith("compiled C")] == [f"compiled C for {n}" for n in names]
    assert all(library_path(name).is_file() for name in names)
    again = prepare_c(names, workers=2)          # everything is in the cache now
    assert all(s.reused for s in again)
