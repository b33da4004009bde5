"""What every derivation shares: named steps, function specs, constants (``core``), and small exact
linear algebra (``linalg``: 2 x 2 and 3 x 3 solves; ``solve6``: Gram-Schmidt QR, adjugate, back
substitution; ``float_facts``: two SymPy Float queries answered from the number while a derivation runs,
speed only). The derivations themselves live with their models (``models/<kind>/derive.py``)."""

from .core import RANK_TOL, Constant, Derivation, FunctionSpec, StepRecorder, exact_number, expand_steps

__all__ = ["RANK_TOL", "Constant", "Derivation", "FunctionSpec", "StepRecorder", "exact_number", "expand_steps"]
