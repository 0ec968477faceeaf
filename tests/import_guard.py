"""A fresh Python in which some modules cannot be imported, as if they were not installed: what a
worker's code may import is checked by running it there."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Put before a script: refuses every module named in ``REFUSED`` (a package with its submodules).
_REFUSE = """
import sys

REFUSED = {refused!r}


class Refuse:
    def find_spec(self, name, path=None, target=None):
        if any(name == refused or name.startswith(refused + ".") for refused in REFUSED):
            raise ImportError(f"{{name}} is refused here")
        return None


sys.meta_path.insert(0, Refuse())
"""


def run_refusing(script: str, refused: Sequence[str], *arguments: str,
                 timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """Run ``script`` (with ``arguments`` in ``sys.argv[1:]``) in a fresh Python of the checkout in
    which the modules ``refused`` cannot be imported; its output is captured as text."""
    prefix = _REFUSE.format(refused=tuple(refused))
    return subprocess.run([sys.executable, "-c", prefix + script, *arguments], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout, env={**os.environ, "PYTHONPATH": str(ROOT)})
