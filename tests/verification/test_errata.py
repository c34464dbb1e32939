"""The recorded errata reproduce exactly: printed != derived, printed - derived
is the pinned discrepancy, the corrected formula equals the derivation, and
the set of errata found is the set recorded."""
import dataclasses

import pytest
import sympy as sp

from derive.verification.claims import ShapeMismatch, compare, context
from derive.verification.judge import claims_by_key, comparison, run_all
from derive.verification.errata import (ARTEFACT, ERRATA, MIXED, REAL, Erratum,
                                        errata_by_key, errata_markdown)


def erratum_id(e: Erratum) -> str:
    return f"({e.equation})-{e.what}"


def the_claim(e: Erratum):
    return claims_by_key()[e.key]


@pytest.mark.parametrize("erratum", ERRATA, ids=erratum_id)
def test_erratum_names_a_transcribed_claim(erratum):
    assert erratum.key in claims_by_key()


@pytest.mark.parametrize("erratum", ERRATA, ids=erratum_id)
def test_printed_differs_from_derived(erratum):
    cmp = comparison(the_claim(erratum))
    assert not cmp.holds
    if the_claim(erratum).kind == "identity":
        assert cmp.exact is not True        # exactly nonzero, or not comparable (shapes)
    # (an atan2 form with a quadrant error points along the right line: its exact
    # direction check holds and the pinned sign factor carries the discrepancy)
    assert cmp.numeric_error > 1e-6         # visibly wrong at the random states


@pytest.mark.parametrize("erratum", ERRATA, ids=erratum_id)
def test_printed_minus_derived_is_the_pinned_discrepancy(erratum):
    cmp = comparison(the_claim(erratum), "pinned")
    assert cmp.holds
    if not isinstance(erratum.discrepancy(context(the_claim(erratum).model)), ShapeMismatch):
        assert cmp.exact is True


@pytest.mark.parametrize("erratum", ERRATA, ids=erratum_id)
def test_corrected_form_equals_derived(erratum):
    cmp = comparison(the_claim(erratum), "corrected")
    assert cmp.holds and cmp.exact is True


@pytest.mark.parametrize("erratum", ERRATA, ids=erratum_id)
def test_erratum_is_classified_and_summarised(erratum):
    assert erratum.origin in (REAL, ARTEFACT, MIXED)
    assert erratum.summary and "\n" not in erratum.summary


def test_the_errata_found_are_the_errata_recorded():
    results = run_all()
    assert [r for r in results if r.verdict == "FAIL"] == []
    found = {r.key for r in results if r.verdict == "erratum"}
    assert found == set(errata_by_key())
    assert len(errata_by_key()) == len(ERRATA)


def test_a_wrong_pin_is_rejected():
    """Pinning half the discrepancy (or a different missing entry) must not pass."""
    e = errata_by_key()[next(k for k in errata_by_key() if k[1] == "1.14")]
    c = context(the_claim(e).model)
    assert not compare(the_claim(e), offset=e.discrepancy(c) / 2).holds
    shape = errata_by_key()[next(k for k in errata_by_key() if k[1] == "3.17")]
    pinned = shape.discrepancy(context("spherical_std"))
    wrong = dataclasses.replace(pinned, missing=pinned.missing[:1])
    assert not compare(the_claim(shape), offset=wrong).holds


def test_a_wrong_quadrant_pin_is_rejected():
    e = next(x for x in ERRATA if x.equation == "5.3")
    c = context(the_claim(e).model)
    pinned = e.discrepancy(c)
    flipped = dataclasses.replace(pinned, rho=-pinned.rho)
    assert not compare(the_claim(e), offset=flipped).holds


def test_a_wrong_correction_is_rejected():
    e = next(x for x in ERRATA if x.equation == "1.15")
    c = context(the_claim(e).model)
    assert not compare(the_claim(e), printed=sp.Matrix([0, c.m2 * c.g])).holds   # = as printed


def test_errata_markdown_table():
    table = errata_markdown()
    lines = table.strip().splitlines()
    assert lines[0].startswith("| Seed | Eq. |") and len(lines) == 2 + len(ERRATA)
    for e in ERRATA:
        assert f"({e.equation})" in table and e.summary.replace("|", "\\|") in table
