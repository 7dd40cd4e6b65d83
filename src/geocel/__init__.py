"""geocel: explicit Coupled Eulerian–Lagrangian simulation of pile installation in sand.

Public API (mirrors the scenario file): material parameter classes and the element-test driver.
"""

import hashlib
import os
import shutil
from pathlib import Path


def _kernel_cache() -> None:
    """Point Numba's kernel cache at a directory named after a hash of geocel's sources.

    Numba keys a cached kernel on the timestamp of its own file only, so a kernel that inlines a function of
    another module (the soil models inline into the field kernels) would be loaded stale after that module
    changed: an update could silently run the old physics. One directory per version of the sources avoids
    that; older directories are removed. ``NUMBA_CACHE_DIR``, when set, is left alone."""
    import numba

    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    root = Path(__file__).resolve().parent
    digest = hashlib.sha1()
    for f in sorted(root.rglob("*.py")):
        digest.update(str(f.relative_to(root)).encode())
        digest.update(f.read_bytes())
    name = f"numba-{digest.hexdigest()[:16]}"
    for base in (root / "__pycache__", Path.home() / ".cache" / "geocel"):
        try:
            (base / name).mkdir(parents=True, exist_ok=True)
        except OSError:
            continue  # a read-only installation: the user's cache directory
        for old in base.glob("numba-*"):
            if old.name != name:
                shutil.rmtree(old, ignore_errors=True)
        numba.config.CACHE_DIR = str(base / name)
        return


_kernel_cache()

from .config.materials import PRESETS  # noqa: E402, Elastic, Hypoplastic, MohrCoulomb, Tresca, load_material
from .element_test.driver import ElementTestResult, element_test  # noqa: E402

__all__ = [
    "PRESETS",
    "Elastic",
    "ElementTestResult",
    "Hypoplastic",
    "MohrCoulomb",
    "Tresca",
    "element_test",
    "load_material",
]
__version__ = "0.1.0"
