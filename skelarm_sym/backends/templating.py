"""The Jinja environment of every backend's templates (``templates/<lang>/`` in the source tree,
``skelarm_sym.templates`` in the wheel). Templates lay text out; they hold no algorithm and print
text that is data only through the escapes of :mod:`skelarm_sym.backends.text`."""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path

import jinja2

from .text import c_comment, line_comment, py_string


@lru_cache(maxsize=1)
def environment() -> jinja2.Environment:
    try:
        folder = Path(str(resources.files("skelarm_sym.templates")))
    except ModuleNotFoundError:  # a source checkout: templates/ beside the package
        folder = Path(__file__).resolve().parents[2] / "templates"
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(folder)),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters.update(c_comment=c_comment, py_string=py_string, line_comment=line_comment)
    return env


def render_template(name: str, **context) -> str:
    """Render template ``name`` (a path under ``templates/``) with ``context``."""
    return environment().get_template(name).render(**context)
