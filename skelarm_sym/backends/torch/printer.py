"""PyTorch's names for the array printers of :mod:`skelarm_sym.backends.array_syntax`."""

from __future__ import annotations

from ..array_syntax import FULL, Dialect, ProcedurePrinter, TensorPrinter, identifier

TORCH = Dialect(
    where="torch.where",
    calls={"sqrt": "_sqrt", "sin": "torch.sin", "cos": "torch.cos", "fabs": "torch.abs", "floor": "torch.floor",
           "nearbyint": "torch.round", "isfinite": "torch.isfinite", "atan2": "torch.atan2", "fmin": "torch.minimum",
           "fmax": "torch.maximum"},
    int_dtype="torch.int64",
    bool_dtype="torch.bool",
    cast="{x}.to({dtype})",
)

__all__ = ["FULL", "TORCH", "Dialect", "ProcedurePrinter", "TensorPrinter", "identifier"]
