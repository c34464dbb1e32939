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
    assert any(r.startswith("regular,heyoka-numbers taylor") for r in rows)
    assert any(r.startswith("regular,derive-specialised ") for r in rows)
    assert any(r.startswith("one call,derive-specialised dop853,simulate") for r in rows)
    assert (tmp_path / "race.png").stat().st_size > 10_000


def test_heyoka_with_the_parameters_folded_in_integrates_the_same_equations():
    """heyoka's second setting (the parameters written in as numbers) is the par[] system at
    the race's parameter values."""
    hy = race._heyoka()
    rng = np.random.default_rng(5)
    y = np.column_stack([rng.uniform(-3, 3, (50, 2)), rng.uniform(-4, 4, (50, 2))])
    by_par, folded = (race.heyoka_system(hy, f) for f in (False, True))
    f_par = hy.cfunc([rhs for _, rhs in by_par], vars=[v for v, _ in by_par])
    f_num = hy.cfunc([rhs for _, rhs in folded], vars=[v for v, _ in folded])
    pars = np.ascontiguousarray(np.tile(np.array(race.PARAMS)[:, None], 50))
    theirs = f_par(np.ascontiguousarray(y.T), pars=pars)
    assert np.allclose(f_num(np.ascontiguousarray(y.T)), theirs, rtol=1e-13, atol=1e-13)


def test_the_table_pairs_each_derive_setting_with_its_heyoka_setting():
    """Two pairings in one table: derive (p at run time) against heyoka with par[], derive
    specialised (the numbers folded in) against heyoka-numbers; each ratio is the peer's time
    over its derive's; the per-step table pairs the tools by tolerance the same way
    (made-up points: the table's logic, no timing)."""
    P = race.Point
    rows = [race.Row("chaotic", "chaotic", [P("derive taylor", "rtol=1e-10", 2e-4, 1e-9),
                                             P("derive-specialised taylor", "rtol=1e-10", 1e-4, 1e-9),
                                             P("derive-specialised dop853", "rtol=1e-12", 5e-5, 1e-7),
                                             P("heyoka taylor", "tol=1e-10", 1e-4, 1e-9),
                                             P("heyoka-numbers taylor", "tol=1e-10", 5e-5, 1e-9),
                                             P("heyoka-numbers taylor", "tol=1e-8", 1e-5, 1e-6)]),
            race.Row("quad", "quad", [P("derive taylor double-double", "rtol=1e-24", 1e-1, 1e-20),
                                       P("heyoka taylor real128", "tol=1e-24", 1.0, 1e-20)]),
            race.Row("per step", "per step", [P("derive taylor", "order=13 steps=150 rtol=1e-10", 1e-6, 0.0),
                                               P("derive-specialised taylor", "order=13 steps=150 rtol=1e-10",
                                                 4e-7, 0.0),
                                               P("heyoka taylor", "order=13 steps=151 tol=1e-10", 2e-6, 0.0),
                                               P("heyoka-numbers taylor", "order=13 steps=151 tol=1e-10", 5e-7, 0.0)])]
    summary = race.summary_rows(race.Race(rows, "7", "m"))
    assert len(summary) == 2
    chaotic, quad = summary
    assert chaotic["heyoka ratio"] == pytest.approx(0.5)                # heyoka par[] / derive general
    # heyoka-numbers / derive specialised: the points that miss the target (1e-6, 1e-7) do not count
    assert chaotic["heyoka-numbers ratio"] == pytest.approx(0.5)
    assert chaotic["derive-specialised setting"] == "taylor rtol=1e-10"
    assert quad["derive-specialised"] == "-" and quad["heyoka-numbers ratio"] is None   # no such setting there
    assert quad["heyoka ratio"] == pytest.approx(10)
    text = race.markdown(race.Race(rows, "7", "m", "1/2/3"))
    assert "| 1e-10 | 13 | 1 us | 150 | 2 us | 151 | 2.00 | 0.4 us | 0.5 us | 1.25 |" in text
    assert "heyoka-numbers / derive specialised" in text and "load 1/2/3" in text
