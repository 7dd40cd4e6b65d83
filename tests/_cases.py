"""Scenario dicts shared by several test files."""

from __future__ import annotations

import copy

_TINY_PILE = {
    "domain": {
        "symmetry": "quarter", "radius": 0.6, "soil_depth": 0.8, "void_height": 0.2, "fine_size": 0.1,
        "fine_radius": 0.3, "fine_depth": 0.4, "growth": 1.3, "layout": "tensor",
    },
    "soil": {"model": "mohr-coulomb", "preset": "mohr-coulomb-sand", "layers": [{"top": 0.0, "e0": 0.7}]},
    "pile": {"type": "coupled", "diameter": 0.2, "length": 0.6, "initial_embedment": 0.1},
    "loading": {"velocity": 0.5, "penetration": 0.06, "ramp": 0.01},
    "scaling": {"mass_gravity": 100},
    "output": {"history_every": 0.005, "fields_every": 0.03, "checkpoint_every_steps": 100},
}  # fmt: skip


def tiny_pile(name: str) -> dict:
    """A coupled pile jacked 6 cm into a tiny quarter-model Mohr–Coulomb domain (seconds per run), on the
    tensor-product grid: the tests of the run machinery (restarts, outputs, sweeps) vary its fine_size freely,
    which the default cylindrical layout allows only as pile radius / n (tests/test_cylindrical_scenario.py runs
    that layout through the same machinery)."""
    return {"name": name, **copy.deepcopy(_TINY_PILE)}
