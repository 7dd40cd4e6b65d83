"""Run `geocel verify`'s checks, time them, and record the result for docs/validation.md.

Writes the record ``benchmarks/data/validation/verify.json`` (the summary table's row) and rewrites the table of
outcomes in the section "Closed-form and conservation checks (geocel verify)" of docs/validation.md; then
``python -m geocel.analysis.records`` regenerates the summary table. For a cold figure, empty the Numba cache first
(``NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/verify_report.py``).

    python benchmarks/verify_report.py [--no-write]
"""

from __future__ import annotations

import argparse
import time

import numba

from geocel.analysis.records import DOCUMENT, write_record
from geocel.verification.checks import CHECKS, run_checks

BEGIN = "<!-- BEGIN verify table: written by python benchmarks/verify_report.py -->"
END = "<!-- END verify table -->"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    t0 = time.perf_counter()
    report = run_checks(on_done=lambda c, o: print(f"{c.name}: {time.perf_counter() - t0:.1f} s", flush=True))
    seconds = time.perf_counter() - t0
    rows = ["| check | quantity | reference | computed | error | tolerance | pass |", "|---|---|---|---|---|---|---|"]
    for o in report.outcomes:
        cells = [o.check, o.quantity, o.reference, o.computed, f"{o.error:.2g}", f"{o.tolerance:.2g} {o.measure}",
                 "yes" if o.passed else "**no**"]  # fmt: skip
        rows.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    table = "\n".join(rows)
    print(table)
    n_pass = sum(o.passed for o in report.outcomes)
    print(f"{n_pass}/{len(report.outcomes)} pass in {seconds:.0f} s ({numba.get_num_threads()} threads)")
    for name, why in report.failed_to_run.items():
        print(f"did not run: {name}: {why}")
    if args.no_write:
        return
    punch = {o.check: o for o in report.outcomes if o.quantity.startswith("q/c_u")}
    shield = " and ".join(f"{o.computed}" for o in punch.values())
    write_record(
        "verify",
        check=f"`geocel verify`: {len(CHECKS)} checks, {len(report.outcomes)} quantities (r–z, 3D cylindrical, "
        "element tests)",
        against="Shield, Lamé, Hill, ρ g z and K0, mass and energy conservation, MGS invariance, K0 σ'_v and "
        "Coulomb at the shaft, hypoplastic steady state, e_i(p) and oedometric K",
        figure=f"**{n_pass}/{len(report.outcomes)} pass in {seconds:.0f} s** on 2 cores; Shield's punch at 8 cells "
        f"per radius {shield} c_u (r–z, 3D)",
        section="Closed-form and conservation checks (geocel verify)",
        command="geocel verify",
        passed=report.passed,
    )
    text = DOCUMENT.read_text("utf-8")
    start, stop = text.find(BEGIN), text.find(END)
    if start < 0 or stop < start:
        raise SystemExit(f"{DOCUMENT} has no verify table markers")
    DOCUMENT.write_text(text[: start + len(BEGIN)] + "\n" + table + "\n" + text[stop:], "utf-8")


if __name__ == "__main__":
    main()
