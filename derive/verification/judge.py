"""The seeds' claims judged: every transcribed formula (seed_formulas.CLAIMS) compared
with the derivation, and a differing one accepted only as its recorded erratum
(errata.py) that reproduces exactly.

The comparison of one claim is :func:`claims.compare`; this module runs them all, with
the errata, so that the claim kinds (claims.py), their transcriptions
(seed_formulas.py) and the errata (errata.py) import nothing above them.
"""
from __future__ import annotations

import time
from functools import cache

from .claims import Claim, Comparison, Result, compare, context
from .errata import errata_by_key
from .seed_formulas import CLAIMS


def all_claims() -> list[Claim]:
    return list(CLAIMS)


def _brief(x, limit: int = 110) -> str:
    text = str(x).replace("\n", " ")
    return text if len(text) <= limit else text[:limit - 3] + "..."


@cache
def claims_by_key() -> dict:
    table = {}
    for claim in all_claims():
        if claim.key in table:
            raise ValueError(f"claim transcribed twice: {claim.key}")
        table[claim.key] = claim
    return table


@cache
def comparison(claim: Claim, mode: str = "printed") -> Comparison:
    """The claim's comparison, cached per claim object: ``mode`` "printed" (as
    transcribed), "pinned" (printed minus the erratum's pinned discrepancy) or
    "corrected" (the erratum's corrected formula)."""
    key = claim.key
    if mode == "printed":
        return compare(claim)
    erratum = errata_by_key()[key]
    c = context(claim.model)
    if mode == "pinned":
        return compare(claim, offset=erratum.discrepancy(c))
    if mode == "corrected":
        return compare(claim, printed=erratum.corrected(c))
    raise ValueError(mode)


def erratum_problem(claim: Claim) -> str | None:
    """Why a recorded erratum does not reproduce, or None when it does exactly:
    the printed formula differs from the derivation, by exactly the pinned
    discrepancy, and the corrected formula equals the derivation."""
    if comparison(claim).holds:
        return "recorded erratum, but the printed formula now matches the derivation"
    if not comparison(claim, "pinned").holds:
        return ("recorded erratum no longer reproduces: printed - derived = "
                f"{_brief(comparison(claim).discrepancy)}")
    if not comparison(claim, "corrected").holds:
        return "recorded erratum: the corrected formula does not equal the derivation"
    return None


def judge(claim: Claim) -> Result:
    """The verdict of one claim against the derivation and the recorded errata."""
    start = time.perf_counter()
    erratum = errata_by_key().get(claim.key)
    cmp = comparison(claim)
    if erratum is None:
        if cmp.holds:
            verdict, summary = "match", cmp.note or "printed = derived (exact and numeric)"
        else:
            verdict = "FAIL"
            summary = (f"mismatch, not a recorded erratum: exact={cmp.exact}, numeric "
                       f"error {cmp.numeric_error:.3g}; printed - derived = {_brief(cmp.discrepancy)}")
    else:
        problem = erratum_problem(claim)
        verdict, summary = ("erratum", erratum.summary) if problem is None else ("FAIL", problem)
    return Result(claim.seed, claim.equation, claim.what, claim.model, verdict, summary,
                  time.perf_counter() - start)


@cache
def _results() -> tuple[Result, ...]:
    return tuple(judge(claim) for claim in all_claims())


def run_all() -> list[Result]:
    """Every claim judged (cached per process: the derivations do not change under us)."""
    return list(_results())


def judged(keys: tuple[str, ...]) -> list[Result]:
    """The verdicts of the claims with these keys, in their order (one worker's share of
    :func:`judging_calls`).

    Parameters
    ----------
    keys : tuple of str
        Claim keys (Claim.key).

    Returns
    -------
    list of Result
    """
    table = claims_by_key()
    return [judge(table[key]) for key in keys]


def judging_calls(share: int = 8) -> list[tuple]:
    """Every claim's judgement as calls of :func:`judged`, `share` claims of one model a
    call, in claim order: concatenated, their results are :func:`run_all`'s.

    Parameters
    ----------
    share : int
        Claims per call (a worker builds a model's context once, then judges its claims).

    Returns
    -------
    list of (callable, tuple)
    """
    calls, run = [], []
    for claim in all_claims():
        if run and (len(run) == share or claims_by_key()[run[-1]].model != claim.model):
            calls.append((judged, (tuple(run),)))
            run = []
        run.append(claim.key)
    if run:
        calls.append((judged, (tuple(run),)))
    return calls
