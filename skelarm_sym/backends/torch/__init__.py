"""The PyTorch backend (see :mod:`.backend`): ``--lang torch`` writes ``{prefix}_torch.py``."""

from __future__ import annotations

from .backend import FILE_SUFFIXES, LANGUAGE, render

LABEL = "PyTorch"
"""How ``check`` names this backend's implementation."""
SUPPORTS = ("straight", "procedure")
"""The kinds of IR function this backend prints (procedures batched over problems, masked)."""


def load(generated):
    """The emitted module, loaded, behind an adapter that takes and returns NumPy arrays (for ``check``
    and the tests). Without PyTorch: a skip inside a pytest run, else an InputError saying what to install."""
    from ...errors import InputError
    from .adapter import ArrayAdapter, require

    torch = require("torch", "torch")
    name = generated.module.prefix + FILE_SUFFIXES[0]
    from ...build import load_python

    try:
        module = load_python(generated.sources[name], generated.module.prefix + "_torch")
    except SyntaxError as exc:  # a file edited by hand
        raise InputError(f"{name} does not load: {exc.msg} (line {exc.lineno})") from None
    return ArrayAdapter(module, generated.module, lambda x: x.detach().cpu().numpy() if isinstance(x, torch.Tensor) else x)


__all__ = ["FILE_SUFFIXES", "LABEL", "LANGUAGE", "SUPPORTS", "load", "render"]
