"""`derive latex MODEL`: the document of a model (or of the chart atlas), and its PDF.

The command line and the Python face (derive.api) both call `document` and `pdflatex`:
the model is derived and verified, its seed formulas judged and its physics checked,
then typeset (derive/report/latex.py, atlas_document.py).
"""
from __future__ import annotations

import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..derivation import derive
from ..errors import DeriveError, ToolMissingError
from ..model import load_model
from ..model.atlas import ATLAS, load_atlas
from ..verification.cached import physics_model, verify_model
from .atlas_document import render_atlas
from .latex import render

PDFLATEX_MISSING = "pdflatex not found: install TeX Live (texlive-latex-base) or omit --pdf"


@dataclass
class Document:
    """The LaTeX text of a model's document, and the formulas and checks it reports.

    Parameters
    ----------
    text : str
        The standalone LaTeX document.
    results : list
        The verified seed formulas it reports.
    checks : list
        The physics checks it reports.

    Examples
    --------
    >>> Document("%", [], []).text
    '%'
    """
    text: str
    results: list
    checks: list


def document(model: str, paper: str = "a4", progress=None) -> Document:
    """The derivation of `model` as a standalone LaTeX document.

    Parameters
    ----------
    model : str
        A catalogue model name, the path of a model file, or 'spherical' (the chart atlas).
    paper : {'a4', 'letter'}, optional
        The paper size, portrait.
    progress : callable, optional
        Called with a short text before each step (deriving, verifying, typesetting).

    Returns
    -------
    Document
        The text and the verified formulas and physics checks it holds.

    Raises
    ------
    ModelError
        An unknown model or a wrong model file.

    Examples
    --------
    >>> doc = document("planar")
    >>> doc.text.lstrip().startswith("%") and r"\\begin{document}" in doc.text
    True
    """
    say = progress or (lambda text: None)
    if model == ATLAS:
        results, checks = [], []
        for chart in load_atlas(ATLAS).charts:
            say(f"verifying {chart}")
            results += [r for r in verify_model(chart) if r.equation.startswith("5.")]
            checks += [c for c in physics_model(chart) if len(c.models) == 2]
        say("typesetting")
        return Document(render_atlas(results, checks, paper), results, checks)
    description = load_model(model)
    name = description.name
    say(f"deriving {name}")
    d = derive(description)
    say(f"verifying the seed formulas of {name}")
    results = verify_model(name)
    say(f"physics checks of {name}")
    checks = physics_model(description)
    say("typesetting")
    return Document(render(d, results, checks, paper), results, checks)


def pdflatex(tex: Path) -> Path:
    """Compile `tex` twice (references settle) in a temporary folder; only the PDF comes
    back beside it.

    Parameters
    ----------
    tex : pathlib.Path
        A standalone .tex file.

    Returns
    -------
    pathlib.Path
        The PDF beside it.

    Raises
    ------
    ToolMissingError
        No pdflatex on the PATH.
    DeriveError
        pdflatex failed: the log is left beside the .tex and the message names its first error.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     tex = Path(folder) / "planar.tex"
    ...     _ = tex.write_text(document("planar").text)
    ...     pdflatex(tex).name, sorted(p.name for p in Path(folder).iterdir())
    ('planar.pdf', ['planar.pdf', 'planar.tex'])
    """
    exe = shutil.which("pdflatex")
    if exe is None:
        raise ToolMissingError(PDFLATEX_MISSING)
    pdf = tex.with_suffix(".pdf")
    with tempfile.TemporaryDirectory(prefix="derive-latex-") as tmp:
        work = Path(tmp) / tex.name
        shutil.copyfile(tex, work)
        for _ in range(2):
            run = subprocess.run([exe, "-interaction=nonstopmode", "-halt-on-error", work.name],
                                 cwd=tmp, capture_output=True, text=True, errors="replace")
            if run.returncode != 0:
                log = work.with_suffix(".log")
                text = log.read_text(errors="replace") if log.is_file() else run.stdout
                tex.with_suffix(".log").write_text(text)
                first = next((ln for ln in text.splitlines() if ln.startswith("!")), "no error line")
                raise DeriveError(f"pdflatex failed on {tex}: {first[1:].strip()} "
                                  f"(log: {tex.with_suffix('.log')})")
        shutil.copyfile(work.with_suffix(".pdf"), pdf)
    return pdf
