"""What every backend has, and the helpers the language context builders share.

Python decides, templates lay out: a backend prepares every string a template
prints (names, sizes, printed expressions); there is no type dispatch in Jinja.
"""
from __future__ import annotations

import textwrap
from dataclasses import dataclass

from ..spec import ModelSpec

POLAR_SINE_MIN = "1e-6"      # default chart-singularity threshold (overridable in C)


class Backend:
    """One target language.  Subclasses set the class attributes and implement
    `kernel_files`; the integrators, loops and atlas files default to none."""
    name: str                       # templates/<name>/ and <generated tree>/<name>/
    suffixes: tuple[str, ...]       # the files it writes there
    printer: type                   # its SymPy printer (derive/codegen/printers.py)
    reserved: frozenset[str]        # identifiers the language reserves
    # rendered without being asked for: into the golden generated/ and the run time's cache.
    # A language whose code needs an optional extra (jax) is rendered only on request
    # (`derive generate --backend NAME --out DIR`), so that neither the golden tree nor a
    # run pays for it.
    by_default: bool = True

    def kernel_files(self, spec: ModelSpec, bodies) -> dict[str, str]:
        """The model's kernels: path in a generated tree -> text."""
        raise NotImplementedError

    def integrator_files(self, name: str, timed: bool = False) -> dict[str, str]:
        """The integrators of model `name` (derive/codegen/integrators.py renders them);
        timed: the model has explicit time (a backend whose integrators cannot pass t to
        the rhs emits none for it)."""
        return {}

    def early_work(self, name: str):
        """(work, keep) for work on model `name` that needs its spec but not the kernels'
        CSE, or None (the default): sources runs work(name) in a worker while the CSE runs
        and hands its picklable result to keep(name, result) in this process before the
        backend renders (keep(name, None) after: forget it).  Whatever work would give, the
        files must be the same without it."""
        return None

    def loop_files(self, name: str) -> dict[str, str]:
        """The fixed-step and batched loops (only for a model without chart guards)."""
        return {}

    def atlas_files(self, name: str) -> dict[str, str]:
        """The chart atlas `name`'s own files (its member charts are ordinary models)."""
        return {}

    def model_files(self, name: str, spec: ModelSpec, bodies, guarded: bool) -> dict[str, str]:
        """Every artifact this language emits for one model."""
        files = dict(self.kernel_files(spec, bodies))
        files.update(self.integrator_files(name, spec.is_time_dependent))
        if not guarded:         # a time-dependent model's too: each stage's t inlined
            files.update(self.loop_files(name))
        return files

    def __repr__(self) -> str:
        return f"<derive backend {self.name}>"


def own(files: dict[str, str], folder: str) -> dict[str, str]:
    """The files of a renderer that emits several languages at once that lie in `folder`."""
    return {rel: text for rel, text in files.items() if rel.split("/", 1)[0] == folder}


def wrap(text: str, width: int = 88) -> list[str]:
    return textwrap.wrap(" ".join(text.split()), width) or [""]


def join_terms(terms: list[str], sep: str, width: int) -> list[str]:
    """terms joined by sep, broken into lines between terms, never inside one."""
    lines, line = [], ""
    for term in terms:
        piece = term if not line else sep + term
        if line and len(line) + len(piece) > width:
            lines.append(line + sep.rstrip())
            line = term
        else:
            line += piece
    return lines + [line] if line else lines


def slot_doc(vector) -> str:
    return ", ".join(vector.names)


def common_context(spec: ModelSpec, template: str) -> dict:
    """What every language's kernel template reads about a model."""
    return {
        "template": template,
        "model": spec.name,
        "title": spec.title,
        "source": spec.source,
        "vectors": [{"count": v.count, "table": v.table, "size": v.size,
                     "names": list(v.names), "names_py": repr(tuple(v.names)),
                     "names_c": ", ".join(f'"{n}"' for n in v.names), "doc": v.doc}
                    for v in spec.vectors],
        "has_guards": spec.has_guards,
        "polar_sine_min": POLAR_SINE_MIN,
    }


@dataclass(frozen=True)
class Variant:
    ctype: str        # C type of the variant
    suffix: str       # appended to every function name
    label: str


def unflatten(flat: list, like: list[list]) -> list[list]:
    """flat, cut into lists of the lengths of like's."""
    out, i = [], 0
    for exprs in like:
        out.append(flat[i:i + len(exprs)])
        i += len(exprs)
    return out
