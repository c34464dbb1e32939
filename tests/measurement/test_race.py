"""The heyoka race: the peer integrates the same equations, and the race runs end to end."""
from __future__ import annotations

import numpy as np
import pytest

from derive.runtime.loader import load
from derive.measurement import race


def test_heyoka_peer_has_the_generated_right_hand_side():
    """The equations handed to heyoka (seed 000 (1.34)-(1.35)) are the derived ones."""
    hy = race._heyoka()
    system = race.heyoka_system(hy)
    variables = [v for v, _ in system]
    f = hy.cfunc([rhs for _, rhs in system], vars=variables)
    rng = np.random.default_rng(4)
    y = np.column_stack([rng.uniform(-3, 3, (200, 2)), rng.uniform(-4, 4, (200, 2))])
    p = np.column_stack([rng.uniform(0.3, 3, (200, 4)), np.full(200, 9.81)])
    theirs = f(np.ascontiguousarray(y.T), pars=np.ascontiguousarray(p.T)).T
    ours = load("planar").rhs(y, p)
    assert np.allclose(theirs, ours, rtol=1e-12, atol=1e-12)


def test_ensemble_of_heyoka_and_derive_agree_on_a_small_batch():
    hy = race._heyoka()
    y0 = race.ensemble_states(16, seed=1)
    theirs = race._heyoka_ensemble(hy, race.heyoka_system(hy), y0, 1.0, 1e-15, 4, 2)()
    import derive
    ours = derive.ensemble("planar", y0, [0, 1.0], race.PARAMS, rtol=1e-13).y[:, -1]
    assert np.max(np.abs(theirs - ours)) < 1e-9


@pytest.mark.slow
def test_race_quick_writes_its_table(tmp_path):
    from derive.cli import main
    assert main(["bench", "--race", "--quick", "--quiet", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "race.md").read_text()
    for row in ("regular", "chaotic", "one call"):
        assert row in text
    rows = (tmp_path / "race.csv").read_text().splitlines()
    assert any(r.startswith("regular,heyoka taylor") for r in rows)
    assert (tmp_path / "race.png").stat().st_size > 10_000
