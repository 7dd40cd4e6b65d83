"""geocel: explicit Coupled Eulerian–Lagrangian simulation of pile installation in sand.

Public API (mirrors the scenario file): material parameter classes and the element-test driver.
"""

from .config.materials import PRESETS, Elastic, Hypoplastic, MohrCoulomb, Tresca, load_material
from .element_test.driver import ElementTestResult, element_test

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
