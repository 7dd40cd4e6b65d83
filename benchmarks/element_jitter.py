"""How the hypoplastic sand responds to strain jitter: one material point, no grid
(docs/studies/2026-11-25-pile-frame.md).

The ``deeks-white`` preset's sand (Fraction E), dense (e = 0.58), from σ = (−25, −25, −50) kPa, strained
along a fixed compressive direction D₀ ∝ (0.25, 0.25, −1) in increments of 10⁻⁴ (= R) to 20 %. On every
increment a random strain of η times its size (a random direction in the 11, 22, 33, 13 components, zero on
average) is superimposed. This is what the grid-scale shaking of a jacked pile's soil looks like to the
soil model. Prints the mean stress p at 5, 10 and 20 % strain against η, with and without the intergranular
strain, and the change relative to η = 0.

    python benchmarks/element_jitter.py [--eta 0 0.1 0.2 0.3 0.5 1] [--seed 1]
"""

from __future__ import annotations

import argparse

import numpy as np

from geocel.benchmark.presets import preset_scenario
from geocel.materials.kernels import update_cells

STEP = 1e-4  # strain of one increment (= R of the preset's sand)
CHECKPOINTS = (500, 1000, 2000)  # increments: 5, 10, 20 % strain


def run(etas: list[float], intergranular: bool, seed: int = 1) -> np.ndarray:
    """Mean stress p (Pa, compression positive) at :data:`CHECKPOINTS` for every η: shape (checkpoints, η)."""
    mat = preset_scenario("deeks-white").soil.material.model_copy(
        update={"intergranular_strain": intergranular}
    )
    prm = mat.to_array()
    n = len(etas)
    stress = np.tile(np.array([-25e3, -25e3, -50e3, 0.0, 0.0, 0.0]), (n, 1))
    state = np.zeros((n, len(mat.state_names)))
    state[:, 0] = 0.58
    if intergranular:
        state[:, 3] = -mat.R  # fully mobilised along the last (vertical, compressive) loading
    modulus = np.zeros(n)
    flags = np.zeros(n, dtype=np.int32)
    d0 = np.array([0.25, 0.25, -1.0, 0.0, 0.0, 0.0])
    d0 /= np.linalg.norm(d0)
    rng = np.random.default_rng(seed)
    eta = np.asarray(etas)[:, None]
    out = []
    for it in range(1, CHECKPOINTS[-1] + 1):
        noise = rng.normal(size=(n, 6))
        noise[:, 3] = 0.0
        noise[:, 5] = 0.0
        noise /= np.linalg.norm(noise, axis=1)[:, None]
        d = STEP * (d0[None, :] + eta * noise)
        update_cells(
            mat.model_id, prm, stress, state, d, np.zeros((n, 3)), mat.substep_strain(0.1), modulus, flags
        )
        if it in CHECKPOINTS:
            out.append(-stress[:, :3].sum(axis=1) / 3.0)
    return np.array(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--eta", type=float, nargs="+", default=[0.0, 0.1, 0.2, 0.3, 0.5, 1.0])
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    if a.eta[0] != 0.0 or any(e < 0 for e in a.eta):
        ap.error("--eta: non-negative, starting with 0 (the reference)")
    for igs in (True, False):
        p = run(a.eta, igs, a.seed)
        print(f"{'with' if igs else 'without'} intergranular strain: p (kPa) and change against η = 0")
        print("  strain " + "".join(f"{'η = ' + format(e, 'g'):>20s}" for e in a.eta))
        for c, row in zip(CHECKPOINTS, p, strict=True):
            cells = "".join(f"{x / 1e3:11.0f} {100 * (x / row[0] - 1):+6.1f} %" for x in row)
            print(f"  {c * STEP:5.0%} {cells}")


if __name__ == "__main__":
    main()
