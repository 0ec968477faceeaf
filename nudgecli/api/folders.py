"""Where the API's results live: a folder of one's own (kept) or a temporary one (removed).

A :class:`~nudgecli.api.run.Run` or :class:`~nudgecli.api.analysis.Analysis` made without
``out=`` writes into a temporary folder that goes away with the object: on ``close()``, at the
end of a ``with`` block, or when it is garbage-collected (:func:`weakref.finalize`, which also
runs at interpreter exit), as :class:`tempfile.TemporaryDirectory` does for its own folder.
"""

from __future__ import annotations

import shutil
import tempfile
import weakref
from pathlib import Path
from types import TracebackType
from typing import Self


class FolderOwner:
    """Base of the results that hold a folder: ``path``, and ``close()`` / ``with`` for a temporary one.

    Attributes
    ----------
    path
        The folder.
    temporary
        Whether the folder is removed when the object is closed or collected.
    """

    path: Path
    temporary: bool

    def _own(self, path: Path, temporary: bool, holder: Path | None = None) -> None:
        """Hold ``path``; when ``temporary``, remove ``holder`` (default ``path``) with this object."""
        self.path = path
        self.temporary = temporary
        removed = holder if holder is not None else path
        # the finalizer holds the folder's path, never the object: it can still be collected
        self._finalizer = weakref.finalize(self, shutil.rmtree, removed, True) if temporary else None

    def close(self) -> None:
        """Remove the folder now if it is temporary (a kept folder is left as it is); idempotent."""
        if self._finalizer is not None:
            self._finalizer()

    @property
    def closed(self) -> bool:
        """True once a temporary folder has been removed."""
        return self._finalizer is not None and not self._finalizer.alive

    def __enter__(self) -> Self:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.close()


def temporary_folder(prefix: str) -> Path:
    """A new, empty folder under the system's temporary directory (``nudge-<prefix>-...``)."""
    return Path(tempfile.mkdtemp(prefix=f"nudge-{prefix}-"))


def remove_if_made(folder: Path, made: bool) -> None:
    """Remove ``folder`` when this call made it (``made``): a failed call leaves nothing behind."""
    if made:
        shutil.rmtree(folder, ignore_errors=True)
