"""The Python face of the pipeline: a model as one object, as `derive` on the command line.

    model = derive.load_model("planar")          # or the path of a model file
    eq = model.equations()                       # SymPy: eq.M, eq.F, eq.T, eq.V, eq.L, eq.H
    model.generate(out="gen", backends=("c", "numpy", "jax"))
    model.latex(out="planar.tex", pdf=True)
    r = model.simulate(y0, t, params)            # derive.simulate

Each method calls the functions the command does (`derive generate`, `derive latex`), so
the two cannot drift apart.  This module sits above the stages it drives (pyproject.toml,
[tool.importlinter]); `import derive` imports it on first use only.
"""
from __future__ import annotations

import os
from pathlib import Path

from .codegen.backends import selected
from .codegen.generate import write_models
from .derivation import derive
from .errors import UsageError
from .model import Model, load_model as load_description
from .report.document import document, pdflatex
from .report.equations import Equations, equations_of
from .runtime.result import SimulationResult
from .runtime.simulate import simulate
from .paths import writable_dir

__all__ = ["Pendulum", "equations", "load_model"]


class Pendulum:
    """A model of the catalogue or of a model file, with what derive makes of it.

    Parameters
    ----------
    description : Model
        The model's description (derive/model/), as `load_model` reads it.

    Examples
    --------
    >>> model = load_model("planar")
    >>> model
    <derive model planar: Planar double pendulum with point masses>
    >>> model.coordinates, model.parameters
    (('theta1', 'theta2'), ('m1', 'm2', 'l1', 'l2', 'g'))
    """

    def __init__(self, description: Model):
        self.description = description

    @property
    def name(self) -> str:
        """The model's name (its generated files are called so)."""
        return self.description.name

    @property
    def title(self) -> str:
        """Its one-line description."""
        return self.description.title

    @property
    def coordinates(self) -> tuple[str, ...]:
        """The names of its generalized coordinates."""
        return tuple(self.description.coordinate_names)

    @property
    def parameters(self) -> tuple[str, ...]:
        """The names of its parameters, in the order of a parameter vector."""
        return tuple(self.description.parameters)

    def __repr__(self) -> str:
        return f"<derive model {self.name}: {self.title}>"

    def equations(self) -> Equations:
        """The derivation as SymPy objects (derived once, then read from the cache).

        Returns
        -------
        Equations
            M, F, T, V, L, the energy, the Hamiltonian form where the model has it, the
            coordinates and the parameters; shown typeset in a notebook.

        Examples
        --------
        >>> eq = load_model("planar").equations()
        >>> eq.M.shape, [s.name for s in eq.parameters]
        ((2, 2), ['m1', 'm2', 'l1', 'l2', 'g'])
        >>> import sympy as sp
        >>> sp.simplify(eq.L - (eq.T - eq.V))
        0
        """
        return equations_of(derive(self.description))

    def generate(self, out, backends=None, check: bool = False) -> list[Path]:
        """Write the model's generated code into `out`, as `derive generate MODEL --out OUT`.

        Parameters
        ----------
        out : str or os.PathLike
            The folder: out/c/, out/numpy/, out/jax/, one per backend.  Other models' files
            there stay.
        backends : tuple of str, optional
            The languages (folders of derive/codegen/backends/): 'c', 'numpy', 'jax'.
            Default: those `derive generate` writes unasked, c and numpy (the ones that
            need no optional extra).
        check : bool, optional
            Write nothing; the returned paths are those that differ.

        Returns
        -------
        list of pathlib.Path
            Every file of the model in `out` (with check=True: those not current).

        Raises
        ------
        UsageError
            An unknown backend name, or a folder that cannot be written.

        Examples
        --------
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as out:
        ...     files = load_model("planar").generate(out, backends=("numpy",))
        ...     sorted(p.name for p in files)[:2]
        ['derive_integrators.py', 'derive_tableaus.py']
        """
        out = Path(out)
        names = tuple(b.name for b in selected(backends))
        if not check:
            _writable(out)
        written = write_models(out, [self.name], names, check=check)
        if check:
            return [Path(path) for path in written.changed]
        return [out / rel for rel in written.files]

    def latex(self, out=None, pdf: bool = False, paper: str = "a4") -> Path:
        """Write the derivation as a standalone .tex, as `derive latex MODEL -o OUT [--pdf]`.

        Parameters
        ----------
        out : str or os.PathLike, optional
            The .tex file (default: <model>.tex in the current folder).
        pdf : bool, optional
            Also compile it with pdflatex (TeX Live), the PDF beside the .tex.
        paper : {'a4', 'letter'}, optional
            The paper size.

        Returns
        -------
        pathlib.Path
            The .tex file, or with pdf=True the PDF.

        Raises
        ------
        UsageError
            A folder that does not exist, or a path that is a folder.
        ToolMissingError
            pdf=True without pdflatex.

        Examples
        --------
        >>> import tempfile, os
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     tex = load_model("planar").latex(os.path.join(folder, "planar.tex"))
        ...     tex.name, "\\\\begin{document}" in tex.read_text()
        ('planar.tex', True)
        """
        if paper not in ("a4", "letter"):
            raise UsageError(f"unknown paper {paper!r} (a4 or letter)")
        tex = Path(out) if out is not None else Path(f"{self.name}.tex")
        if tex.is_dir() or not tex.parent.is_dir():
            raise UsageError(f"cannot write '{tex}': give the path of a .tex file in a folder that exists")
        doc = document(self.name, paper)
        try:
            tex.write_text(doc.text)
        except OSError as exc:
            raise UsageError(f"cannot write '{tex}': {exc.strerror or exc}") from None
        return pdflatex(tex) if pdf else tex

    def simulate(self, y0, t, params, **options) -> SimulationResult:
        """Run the model: ``derive.simulate(model, y0, t, params, **options)``.

        Parameters
        ----------
        y0 : array_like
            The initial state (coordinates, then rates).
        t : array_like
            The output times.
        params : dict or array_like
            The parameters, by name or in order.
        **options
            derive.simulate's options (method, rtol, dtype, ...).

        Returns
        -------
        SimulationResult
            The run; see derive.simulate.

        Raises
        ------
        SimulationInputError
            Arguments derive.simulate refuses (a state of the wrong size, an unknown method).
        BuildError
            backend "c": the model's library cannot be compiled.

        Examples
        --------
        >>> r = load_model("planar").simulate([1.0, 0.5, 0, 0], [0.0, 1.0],
        ...     {"m1": 1, "m2": 1, "l1": 1, "l2": 1, "g": 9.81}, backend="numpy")
        >>> r.ok, r.y.shape
        (True, (2, 4))
        """
        return simulate(self.name, y0, t, params, **options)


def _writable(out: Path) -> None:
    try:
        writable_dir(out)
    except OSError as exc:
        raise UsageError(f"cannot write to '{out}': {exc.strerror or exc}") from None
    except ValueError as exc:          # a NUL byte in the path
        raise UsageError(f"cannot write to {str(out)!r}: {exc}") from None


def load_model(name_or_path) -> Pendulum:
    """A model by catalogue name ('planar', ...) or by the path of a model file (.toml).

    Parameters
    ----------
    name_or_path : str or os.PathLike
        A catalogue name, or a model file (afterwards its name loads it too).

    Returns
    -------
    Pendulum
        The model, whose methods derive, generate, typeset and simulate it.

    Raises
    ------
    ModelError
        An unknown name (the message lists the known ones) or a wrong model file.

    Examples
    --------
    >>> load_model("compound").name
    'compound'
    """
    return Pendulum(load_description(os.fspath(name_or_path)))


def equations(model) -> Equations:
    """The equations of `model`: a Pendulum, a catalogue name or the path of a model file.

    Parameters
    ----------
    model : Pendulum or str or os.PathLike
        The model.

    Returns
    -------
    Equations
        As Pendulum.equations.

    Raises
    ------
    ModelError
        An unknown name or a wrong model file.

    Examples
    --------
    >>> equations("planar").coordinates
    (theta1, theta2)
    """
    return (model if isinstance(model, Pendulum) else load_model(model)).equations()
