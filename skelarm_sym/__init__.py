"""skelarm-sym: closed-form differential kinematics of serial arms as fast, checked code."""

from .derive import Derivation
from .errors import InputError
from .models import DiffDrive, PlanarArm
from .models import load_robot

__version__ = "0.4.0"


def derive(model, lengths=None) -> Derivation:
    """The derivation of any model: a number of links (with ``lengths``: ``None`` for symbolic lengths,
    else ``n`` numbers), a :class:`PlanarArm`, a :class:`DiffDrive`, or a 3-D chain from
    :func:`load_robot`. Raises :class:`InputError` (a ``ValueError``) on bad input."""
    from .models.registry import derive as derive_model

    if isinstance(model, (int, float)) and not isinstance(model, bool):
        model = PlanarArm(model, lengths)
    elif isinstance(model, bool):
        raise InputError(f"number of links must be a whole number, got {model!r}")
    return derive_model(model)


__all__ = ["Derivation", "DiffDrive", "InputError", "PlanarArm", "__version__", "derive", "load_robot"]
