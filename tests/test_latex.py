"""The LaTeX documents as a reader sees them: compiled here (the log kept), pages turned into
PNG, the text extracted; no mis-encoded glyphs, no overfull lines, every seed equation."""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# pdflatex, pdftotext and pdftoppm are required, never skipped for: tests/run.sh installs them

USER_MODEL = """\
name = "rodtip"
title = "Planar double pendulum: a rod with a point mass at its tip"
source = "a user's model file"
dimension = 2
parameters = ["m1", "m2", "l1", "l2", "L1", "g"]

[[links]]
chart = "planar"
length = "l1"
body = { kind = "rod", mass = "m1", com = "1/2", inertia = "L1" }

[[links]]
chart = "planar"
length = "l2"
body = { kind = "point", mass = "m2" }
"""


def cli(*args, cwd=ROOT):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "derive", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=900)


def equations(model: str) -> set[str]:
    """The numbered seed equations (n.m) of a model's claims, or of section 5 for the atlas."""
    sys.path.insert(0, str(ROOT))
    from derive.verification.claims import all_claims
    eqs = {c.equation for c in all_claims()
           if (c.equation.startswith("5.") if model == "spherical" else c.model == model)}
    return {e for e in eqs if re.fullmatch(r"\d+\.\d+", e)}


def compile_and_read(model: str, tmp_path: Path, paper: str = "a4") -> tuple[str, str, int]:
    """derive latex MODEL, then pdflatex twice here (keeping the log): (text, log, pages)."""
    tex = tmp_path / "doc.tex"
    run = cli("latex", model, "-o", str(tex), "--paper", paper)
    assert run.returncode == 0, run.stdout + run.stderr
    for _ in range(2):
        subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", tex.name],
                       cwd=tmp_path, capture_output=True, text=True, errors="replace", timeout=600)
    log = (tmp_path / "doc.log").read_text(errors="replace")
    pdf = tmp_path / "doc.pdf"
    assert pdf.is_file(), next((ln for ln in log.splitlines() if ln.startswith("!")), log[-2000:])
    subprocess.run(["pdftoppm", "-r", "40", "-png", str(pdf), str(tmp_path / "page")], check=True)
    pages = len(list(tmp_path.glob("page-*.png")))
    text = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True,
                          text=True, check=True).stdout
    return text, log, pages


def check_document(model: str, text: str, log: str, pages: int):
    assert pages >= 1
    assert "¡" not in text and "¿" not in text, "mis-encoded < or > (T1 fonts missing?)"
    assert "Overfull \\hbox" not in log, re.findall(r"Overfull \\hbox.*", log)[:3]
    for pseudo in ("_dot", "**", "theta1", "sqrt("):
        assert pseudo not in text, f"ASCII pseudo-code {pseudo!r} in the PDF"
    missing = [e for e in equations(model) if f"({e})" not in text and e not in text]
    assert not missing, f"seed equations missing from the {model} document: {missing}"
    assert "Physics checks" in text


def test_planar_document_reads_like_a_paper(tmp_path):
    text, log, pages = compile_and_read("planar", tmp_path)
    check_document("planar", text, log, pages)
    assert "Hamiltonian form" in text and "energy conserved" in text
    tex = (tmp_path / "doc.tex").read_text()
    assert r"\usepackage[T1]{fontenc}" in tex and "a4paper" in tex and "landscape" not in tex


def test_user_model_gets_its_physics_checks(tmp_path):
    model = tmp_path / "mine.toml"
    model.write_text(USER_MODEL)
    text, log, pages = compile_and_read(str(model), tmp_path)
    check_document("rodtip", text, log, pages)
    assert "symmetric positive" in text and "energy conserved" in text
    assert "no printed formulas in the seeds" in text.replace("\n", " ")


def test_letter_paper_and_no_aux_files(tmp_path):
    run = cli("latex", "planar", "-o", str(tmp_path / "p.tex"), "--paper", "letter")
    assert run.returncode == 0, run.stderr
    assert "letterpaper" in (tmp_path / "p.tex").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("model", ["compound", "spherical_std", "spherical_alt", "spherical_rot",
                                   "spherical"])
def test_every_catalogue_document_compiles_cleanly(model, tmp_path):
    text, log, pages = compile_and_read(model, tmp_path)
    check_document(model, text, log, pages)
    if model == "spherical":
        assert "spherical_std_to_spherical_rot" in text.replace("\n", "")
        assert "0.3" in text and "0.1" in text and "0.5" in text


def test_a_damped_driven_model_is_written_up_as_such(tmp_path):
    """Dissipation and applied forces: Lagrange's equations with Q - dR/dq', the power
    balance instead of energy conservation, R and Q as formulas, the inputs named."""
    text, log, pages = compile_and_read(str(ROOT / "examples" / "models" / "driven.toml"), tmp_path)
    check_document("driven", text, log, pages)
    flat = " ".join(text.split())
    assert "power balance" in flat and "is conserved" not in flat
    assert "Dissipation" in flat and "Rayleigh" in flat and "Applied forces" in flat
    assert "run-time inputs" in flat and "model file driven.toml" in flat


def test_a_triple_pendulum_has_its_hamiltonian_form_without_a_closed_inverse(tmp_path):
    text, log, pages = compile_and_read(str(ROOT / "examples" / "models" / "triple.toml"), tmp_path)
    check_document("triple", text, log, pages)
    flat = " ".join(text.split())
    assert "Hamiltonian form" in flat and "solved in the code" in flat
