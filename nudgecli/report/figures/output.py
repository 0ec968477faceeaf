"""Writing figures: each format through :func:`nudgecli.store.atomic_path` (the usual permissions)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from nudgecli.errors import ConfigError
from nudgecli.report.style import figure_style
from nudgecli.store import atomic_path

SUPPORTED_FORMATS = ("png", "pdf", "svg")
PNG_DPI = 300
#: Metadata that would make the files differ from run to run (dates, versions): left out.
_METADATA: dict[str, dict[str, Any]] = {
    "png": {"Software": None},
    "pdf": {"CreationDate": None, "Producer": None},
    "svg": {"Date": None},
}


def check_formats(formats: Sequence[str]) -> tuple[str, ...]:
    """The formats, normalised (``".PNG"`` -> ``"png"``), or a :class:`ConfigError` naming a bad one."""
    fmts = tuple(f.strip().lower().lstrip(".") for f in formats if f.strip())
    bad = [f for f in fmts if f not in SUPPORTED_FORMATS]
    if bad or not fmts:
        shown = repr(bad[0]) if bad else "(none)"
        raise ConfigError(f"figure format {shown} is not supported; use one or more of "
                          f"{', '.join(SUPPORTED_FORMATS)} (e.g. --formats png,pdf)")
    return fmts


def save_figure(fig: Figure, out_dir: str | os.PathLike[str], stem: str,
                formats: Sequence[str] = ("png", "pdf"), *, dpi: int = PNG_DPI) -> list[Path]:
    """Write a figure in each format, atomically (:func:`nudgecli.store.atomic_path`).

    Parameters
    ----------
    fig
        The figure.
    out_dir
        Folder (created if missing).
    stem
        File name without suffix.
    formats
        Any of ``png``, ``pdf``, ``svg``.
    dpi
        Resolution of raster output.

    Returns
    -------
    list[Path]
        The written files, in the order of ``formats``.

    Raises
    ------
    ConfigError
        An unsupported format.
    """
    fmts = check_formats(formats)
    out = Path(out_dir)
    written = []
    with figure_style():
        for fmt in fmts:
            target = out / f"{stem}.{fmt}"
            with atomic_path(target) as tmp, open(tmp, "wb") as handle:
                fig.savefig(handle, format=fmt, dpi=dpi, metadata=_METADATA[fmt])
            written.append(target)
    return written


__all__ = ["PNG_DPI", "SUPPORTED_FORMATS", "check_formats", "save_figure"]
