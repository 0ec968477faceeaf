"""One seed gives the same tables on every CPU: a run made with numpy's CPU-specific loops and
OpenBLAS' kernel for this CPU equals, byte for byte, a run made as on a CPU without AVX
(``NPY_DISABLE_CPU_FEATURES`` switches numpy's dispatched loops off, ``OPENBLAS_CORETYPE``
forces an old kernel). Before the model's logs, exponentials and products went through
``nudgecli.model.portable_math``, the baselines preset's robot paths differed between the two.

On a CPU without AVX-512, numpy's part changes nothing, and OpenBLAS' kernel still does."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import files_of

ROOT = Path(__file__).resolve().parents[1]


def _numpy_dispatch_targets() -> list[str]:
    """The CPU targets numpy dispatches to on this machine (none when numpy does not say)."""
    try:
        from numpy._core import _multiarray_umath as umath  # numpy >= 2
    except ImportError:  # pragma: no cover - numpy 1.26
        from numpy.core import _multiarray_umath as umath  # type: ignore[no-redef]
    features = getattr(umath, "__cpu_features__", {})
    return [name for name in getattr(umath, "__cpu_dispatch__", []) if features.get(name)]


def _environment(old_cpu: bool) -> dict[str, str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    for name in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES", "NPY_ENABLE_CPU_FEATURES"):
        env.pop(name, None)
    if old_cpu:
        env["OPENBLAS_CORETYPE"] = "Prescott"
        targets = _numpy_dispatch_targets()
        if targets:
            env["NPY_DISABLE_CPU_FEATURES"] = " ".join(targets)
    return env


def _nudge(env: dict[str, str], *arguments: str) -> None:
    result = subprocess.run([sys.executable, "-m", "nudgecli.cli", *arguments], cwd=ROOT, env=env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr


def _tables(run: Path) -> dict[str, bytes]:
    """Every file of a run or analysis folder but the manifest, whose times differ by nature."""
    return {name: data for name, data in files_of(run).items() if Path(name).name != "manifest.json"}


@pytest.mark.parametrize("preset", ["baselines", "study-code"])
def test_a_run_is_the_same_on_a_cpu_without_avx(tmp_path: Path, preset: str) -> None:
    runs = {}
    for old_cpu in (False, True):
        run = tmp_path / f"{preset}-{'old' if old_cpu else 'this'}-cpu"
        env = _environment(old_cpu)
        _nudge(env, "simulate", preset, "--participants", "1", "--seed", "11", "--workers", "1",
               "--out", str(run))
        _nudge(env, "analyze", str(run), "--out", str(run / "analysis"))
        runs[old_cpu] = run
    this_cpu, old_cpu_run = (_tables(runs[False]), _tables(runs[True]))
    assert this_cpu.keys() == old_cpu_run.keys()
    differing = [name for name in this_cpu if this_cpu[name] != old_cpu_run[name]]
    assert differing == [], f"{preset}: these files depend on the CPU: {differing}"
    checksums = [json.loads((run / "manifest.json").read_text())["checksums"] for run in runs.values()]
    assert checksums[0] == checksums[1]
