"""A new run folder's default place: ``results/<experiment>-<UTC timestamp>/``, never an existing one."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

from nudgecli.errors import RunFolderError


def default_run_dir(experiment: str, root: Path | None = None) -> Path:
    """A new, empty ``results/<experiment>-<UTC timestamp>/`` under the current directory (or ``root``).

    The folder is created here (``mkdir`` fails if it exists), so two runs started in the same
    second get different folders: the second gets ``...Z-2``, the third ``...Z-3``, and so on.

    Raises
    ------
    WriteError
        The results folder cannot be created.
    """
    from nudgecli.store import write_error  # store builds on this module

    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    base = (root or Path("results")) / f"{experiment}-{stamp}"
    try:
        base.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(base.parent, exc) from exc
    for attempt in range(1, 10_000):
        candidate = base if attempt == 1 else base.with_name(f"{base.name}-{attempt}")
        try:
            candidate.mkdir()
        except FileExistsError:
            continue
        except OSError as exc:
            raise write_error(candidate, exc) from exc
        return candidate
    raise RunFolderError(f"{base.parent}: too many runs named {base.name}; choose --out")
