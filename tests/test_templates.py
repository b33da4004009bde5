"""Which templates a copy of the package prints through (skelarm_sym/backends/templating.py).

An editable install maps ``skelarm_sym.templates`` to its own checkout's folder, whichever copy of the package
is imported; the benchmarks' ``--before`` runs another checkout's code with ``PYTHONPATH``. A copy of the
package that lies in a source checkout must print through that checkout's templates, else the comparison
measures new templates under old code."""

from importlib import resources
from pathlib import Path

from skelarm_sym.backends.templating import template_folder


def _checkout(root: Path, marker: bool = True) -> Path:
    """A source checkout's layout under ``root``: ``templates/c/``, the package, and ``pyproject.toml`` when
    ``marker``; the path of its ``templating.py``."""
    (root / "templates" / "c").mkdir(parents=True)
    module = root / "skelarm_sym" / "backends" / "templating.py"
    module.parent.mkdir(parents=True)
    module.write_text("")
    if marker:
        (root / "pyproject.toml").write_text("[project]\nname = 'skelarm-sym'\n")
    return module


def test_a_copy_in_a_source_checkout_prints_through_that_checkouts_templates(tmp_path):
    module = _checkout(tmp_path / "older")
    assert template_folder(module) == (tmp_path / "older" / "templates").resolve()


def test_a_copy_outside_a_checkout_prints_through_the_installed_templates(tmp_path):
    module = _checkout(tmp_path / "site-packages", marker=False)  # a wheel: no pyproject.toml beside the package
    assert template_folder(module) == Path(str(resources.files("skelarm_sym.templates")))


def test_this_copy_finds_its_templates():
    folder = template_folder()
    assert (folder / "c" / "source.c.j2").is_file() and (folder / "c" / "sincos.c.j2").is_file()
