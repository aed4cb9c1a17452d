"""Status codes of a grid point, one message each (after diffrax's RESULTS).

Stored in HDF5 as int8 with CF ``flag_values`` / ``flag_meanings`` attributes.
"""

import enum


class Status(enum.IntEnum):
    NOT_COMPUTED = -1
    OK = 0
    MAX_STEPS = 1
    DIVERGED = 2
    CHATTER_LIMIT = 3
    STEP_TOO_SMALL = 4
    NON_FINITE = 5
    SLIDING = 6


MESSAGES = {
    Status.NOT_COMPUTED: "not computed yet",
    Status.OK: "integrated to the end of the measurement window",
    Status.MAX_STEPS: "stopped at the step cap (integration.max_steps)",
    Status.DIVERGED: "|x| or |v| exceeded integration.divergence_bound",
    Status.CHATTER_LIMIT: "more impacts in one slow period than integration.max_impacts_per_period",
    Status.STEP_TOO_SMALL: "the step size fell below the floating-point resolution of t",
    Status.NON_FINITE: "a non-finite value (NaN or inf) appeared in the state or its derivative",
    Status.SLIDING: "the force points into a jump of a written acceleration (sign) from both sides on a "
                    "surface other than v = constant: a sliding motion, which vrsweep does not follow",
}

FLAG_VALUES = [int(s) for s in Status]
FLAG_MEANINGS = " ".join(s.name.lower() for s in Status)


def message(code: int) -> str:
    return MESSAGES[Status(int(code))]


# The kind of motion a point settled into (vrsweep.analysis.motion decides it), stored as int8
# ``motion`` with flag_values / flag_meanings like the status.
class Motion(enum.IntEnum):
    NONE = 0
    PERIODIC = 1
    QUASI_PERIODIC = 2
    CHAOTIC = 3
    NOT_SETTLED = 4


MOTION_MEANINGS = " ".join(kind.name.lower() for kind in Motion)
