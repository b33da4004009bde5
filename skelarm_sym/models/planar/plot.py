"""A picture of a planar arm at a pose with its velocity manipulability ellipse.

The ellipse is the set of endpoint velocities ``J dq`` reachable with ``|dq| <= 1``:
its semi-axes point along the eigenvectors of ``J J^T`` and have the lengths of
the singular values of ``J``. It flattens to a segment at a singular pose, so a
glance shows how close the pose is to one. Joint positions and ``J`` come from
the NumPy reference. matplotlib is an optional dependency (``pip install 'skelarm-sym[plot]'``).
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ... import reference
from ...errors import InputError


@dataclass(frozen=True)
class PlotSummary:
    """What was drawn: manipulability and the singular values of J (largest first)."""

    path: Path
    manipulability: float
    singular_values: tuple[float, ...]


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError("--plot needs matplotlib: pip install 'skelarm-sym[plot]' (or pip install matplotlib)") from None
    return plt


def plot_arm(pose: Sequence[float], lengths: Sequence[float], path: str | os.PathLike, dpi: int = 120) -> PlotSummary:
    """Draw the arm at ``pose`` (radians, relative joint angles) to the image file ``path``.

    The format follows the suffix (``.png``, ``.svg``, ``.pdf``). The file is
    written to a temporary name first and renamed, so a failure leaves nothing behind.
    """
    q = np.asarray(pose, dtype=float)
    l = np.asarray(lengths, dtype=float)
    if q.ndim != 1 or q.shape != l.shape:
        raise InputError(f"the pose needs one angle per link ({l.size}), got {q.size}")
    if not np.all(np.isfinite(q)):
        raise InputError("the pose must be finite numbers")
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    try:
        is_folder = folder.is_dir()
    except OSError as exc:  # e.g. a name too long for the file system
        raise InputError(f"cannot write plot {str(target)!r}: {exc.strerror or exc}") from None
    if not is_folder:
        raise InputError(f"cannot write plot: folder {str(folder)!r} does not exist")
    plt = _pyplot()

    k = reference.kinematics(q, lengths=l)
    joints = k.joints  # (n + 1, 2): base, joints, endpoint
    J = k.J
    eigenvalues, vectors = np.linalg.eigh(J @ J.T)
    eigenvalues = np.maximum(eigenvalues, 0.0)
    sigma = np.sqrt(eigenvalues)[::-1]
    w = float(np.prod(sigma))
    reach = float(l.sum())
    scale = 0.35 * reach / max(sigma[0], 1e-12)  # the ellipse is drawn at a readable size

    from matplotlib.patches import Ellipse

    fig, ax = plt.subplots(figsize=(5.5, 5.5))
    ax.plot(joints[:, 0], joints[:, 1], "-o", color="#1f4e79", lw=3, ms=6, zorder=2, label="links")
    ax.plot(*joints[0], "s", color="black", ms=9, zorder=3)
    angle = float(np.degrees(np.arctan2(vectors[1, 1], vectors[0, 1])))
    ax.add_patch(Ellipse(tuple(joints[-1]), 2 * scale * sigma[0], 2 * scale * max(sigma[1], 1e-3 * sigma[0]), angle=angle,
                         fill=False, color="#c0392b", lw=2, zorder=4,
                         label=f"velocity ellipse {{J dq : |dq| <= 1}}, drawn at {scale:.3g} x its size"))
    ax.add_patch(plt.Circle((0, 0), reach, fill=False, ls=":", color="grey", lw=1))
    ax.set_aspect("equal")
    ax.set_xlim(-1.15 * reach, 1.15 * reach)
    ax.set_ylim(-1.15 * reach, 1.15 * reach)
    ax.grid(True, alpha=0.3)
    ratio = sigma[1] / sigma[0] if sigma[0] > 0 else 0.0
    ax.set_title(f"{l.size}-link arm: w = {w:.4g}, sigma_min/sigma_max = {ratio:.3g}", fontsize=10)
    ax.legend(loc="lower left", fontsize=8)

    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix or ".png", dir=folder)
        os.close(fd)
        fig.savefig(tmp, dpi=dpi, format=(target.suffix[1:] or "png"))
        from ...files import new_file_mode

        os.chmod(tmp, new_file_mode())
        os.replace(tmp, target)
    except (OSError, ValueError) as exc:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise InputError(f"cannot write plot {str(target)!r}: {reason}") from None
    finally:
        plt.close(fig)
    return PlotSummary(target, w, tuple(float(s) for s in sigma))
