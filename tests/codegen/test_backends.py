"""Target languages are backend objects in folders of their own, discovered by generate."""
from __future__ import annotations

from derive.codegen import backends as backends_pkg
from derive.codegen import sources
from derive.codegen.backends import Backend, backends, default_names, managed_suffixes, selected


def test_every_backend_folder_is_discovered():
    names = [b.name for b in backends()]
    assert names == sorted(names) == ["c", "jax", "numpy"]
    for b in backends():
        assert isinstance(b, Backend) and b.suffixes and b.reserved and b.printer


def test_only_the_backends_that_need_no_extra_are_rendered_unasked():
    """jax needs the jax extra: the golden tree and the run time's cache hold c and numpy."""
    assert default_names() == ("c", "numpy")
    assert [b.name for b in selected()] == ["c", "numpy"]
    assert [b.name for b in selected(["numpy", "jax", "numpy"])] == ["jax", "numpy"]
    assert {rel.split("/")[0] for rel in sources.render_fresh("planar")} == {"c", "numpy"}


def test_each_backend_writes_only_its_folder_and_suffixes():
    """Every file of a model and of the atlas lies in one backend's folder, with its suffix."""
    suffixes = managed_suffixes()
    for name in ("planar", sources.ATLAS):
        files = sources.render_fresh(name)
        assert files
        for rel in files:
            folder, _, leaf = rel.partition("/")
            assert folder in suffixes, rel
            assert leaf.endswith(suffixes[folder]), rel


def test_a_new_backend_is_picked_up_without_wiring(monkeypatch):
    """A backend listed by discovery contributes its artifacts to the generated tree."""
    class Listing(Backend):
        name, suffixes, printer, reserved = "listing", (".txt",), object, frozenset()

        def kernel_files(self, spec, bodies):
            return {f"listing/{spec.name}.txt": "\n".join(k.kernel.name for k in bodies) + "\n"}

    extra = Listing()
    monkeypatch.setattr(backends_pkg, "backends", lambda: (*backends(), extra))
    files = sources._raw("planar")
    assert files["listing/planar.txt"].split() == [b.kernel.name for b in sources.kernels("planar")[1]]
    assert "c/planar.c" in files and "numpy/planar.py" in files
