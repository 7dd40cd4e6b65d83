"""Bit flags a material update returns: which documented special rule fired for a cell.

The batched kernel returns them per cell; callers count them (DESIGN.md §4.3: rules are counted,
never silently applied).
"""

import numpy as np
from numba import njit

LOW_STRESS = 1  #: p below p_min or a tensile principal stress: reset to the isotropic floor -p_min·I
VOID_BELOW_ED = 2  #: e < e_d: evaluated with e = e_d (f_d = 0)
VOID_ABOVE_EI = 4  #: e > e_i: evaluated with e = e_i
ZERO_INCREMENT = 8  #: ‖Δε‖ == 0: constitutive update skipped (only co-rotation applied)
RHO_CLIPPED = 16  #: ‖δ‖ > R after an explicit step: δ scaled back to ‖δ‖ = R
PLASTIC = 32  #: Mohr–Coulomb: plastic return mapping applied
TENSION_CUTOFF = 64  #: Mohr–Coulomb: tension cut-off active
SUBSTEP_LIMIT = 128  #: adaptive substepping hit its minimum step / maximum count
BOUNDED = 256  #: hypoplasticity: stress beyond the base model's bounding surface, deviator scaled back onto it
PLUGIN_NOT_FINITE = 512  #: a UMAT/VUMAT returned a NaN or inf stress, state variable or tangent (the run stops)
PLUGIN_CUTBACK = 1024  #: a UMAT asked for a smaller step (PNEWDT < 1), which an explicit run cannot give (stops)
PLUGIN_UNDEFINED_STATE = 2048  #: a VUMAT left a component of stateNew unwritten (the run stops)
#: the flags that stop a run (a plug-in's failure): :func:`plugin_failure`
PLUGIN_FAILURE = PLUGIN_NOT_FINITE | PLUGIN_CUTBACK | PLUGIN_UNDEFINED_STATE

NAMES = {
    LOW_STRESS: "low_stress",
    VOID_BELOW_ED: "void_below_ed",
    VOID_ABOVE_EI: "void_above_ei",
    ZERO_INCREMENT: "zero_increment",
    RHO_CLIPPED: "rho_clipped",
    PLASTIC: "plastic",
    TENSION_CUTOFF: "tension_cutoff",
    SUBSTEP_LIMIT: "substep_limit",
    BOUNDED: "bounded",
    PLUGIN_NOT_FINITE: "plugin_not_finite",
    PLUGIN_CUTBACK: "plugin_cutback",
    PLUGIN_UNDEFINED_STATE: "plugin_undefined_state",
}

#: what to tell a user about each failure of a plug-in
PLUGIN_ADVICE = {
    PLUGIN_NOT_FINITE: "returned a NaN or inf stress, state variable or DDSDDE: check props (the subroutine may "
    "read more than NPROPS of them: geocel pads PROPS with NaN) and the initial state",
    PLUGIN_CUTBACK: "asked for a smaller time increment (PNEWDT < 1), which an explicit step cannot give: lower "
    "[solver] safety_factor or let the subroutine substep",
    PLUGIN_UNDEFINED_STATE: "left a component of stateNew unwritten (geocel fills it with NaN before the call): "
    "the VUMAT must write every state variable",
}


def count(flags) -> dict[str, int]:
    """Number of cells (or steps) in which each rule fired, from an array of flags."""
    f = np.asarray(flags, dtype=np.int64)
    return {name: int(np.count_nonzero(f & bit)) for bit, name in NAMES.items()}


@njit(cache=True)
def tally(flags, out):
    """``out[b]`` += the number of the ``flags`` (1D) with bit b set, b < len(out): one pass, in which the cells
    that fired no rule (most) cost a test each (numpy's count per bit made a pass per rule that fired)."""
    nb = out.shape[0]
    for c in range(flags.shape[0]):
        x = flags[c]
        if x == 0:
            continue
        for b in range(nb):
            if (x >> b) & 1:
                out[b] += 1
