"""Arrays shared with code that must not change them (a policy's view of its trial, a model shared
by a participant's trials): read-only numpy views of them."""

from __future__ import annotations

import numpy as np


def read_only_array(array: np.ndarray) -> np.ndarray:
    """``array`` as a read-only numpy view (the same values; ``array`` itself stays as it was).

    Parameters
    ----------
    array
        Any shape.

    Returns
    -------
    np.ndarray
        The same shape and memory; writing into it raises ``ValueError``.
    """
    view = np.asarray(array).view()
    view.setflags(write=False)
    return view
