"""One status vocabulary for every outcome the package reports: fits, free runs, posterior samples and
diagnosis candidates (the idea of diffrax's ``RESULTS``: one enumeration, a human message beside it).

A :class:`Status` is a ``str``: its value is exactly the string the JSON outputs have always carried
(IPOPT's own return-status names for a fit, ``"ok"``/``"blow-up"``/``"too stiff"`` for a simulation), so
``json.dumps`` and comparisons with those strings are unchanged (``docs/contract.md``). Code tests members
(``status is Status.BLOW_UP``, ``status.success``) rather than spelling strings.
"""

from __future__ import annotations

from enum import Enum


class Status(str, Enum):
    """What happened, one member per distinct outcome; :attr:`success` says whether the answer is usable
    as far as the producer can tell, :attr:`message` says it in words."""

    # a fit: IPOPT's return status, by IPOPT's name
    SOLVED = "Solve_Succeeded"
    ACCEPTABLE = "Solved_To_Acceptable_Level"
    FEASIBLE_POINT = "Feasible_Point_Found"
    MAX_ITER = "Maximum_Iterations_Exceeded"
    CPU_TIME = "Maximum_CpuTime_Exceeded"
    IPOPT_WALL_TIME = "Maximum_WallTime_Exceeded"
    TIME_LIMIT = "Wall_Time_Exceeded"
    INFEASIBLE = "Infeasible_Problem_Detected"
    SMALL_STEP = "Search_Direction_Becomes_Too_Small"
    DIVERGING = "Diverging_Iterates"
    USER_STOP = "User_Requested_Stop"
    # duffsym's own stop: the cost no longer fell while parameters still moved (identify.nlp.RIDGE_WINDOW)
    RIDGE = "Stalled_On_Ridge"
    RESTORATION_FAILED = "Restoration_Failed"
    STEP_ERROR = "Error_In_Step_Computation"
    FEW_DOF = "Not_Enough_Degrees_Of_Freedom"
    INVALID_PROBLEM = "Invalid_Problem_Definition"
    INVALID_OPTION = "Invalid_Option"
    INVALID_NUMBER = "Invalid_Number_Detected"
    UNRECOVERABLE = "Unrecoverable_Exception"
    NON_IPOPT_EXCEPTION = "NonIpopt_Exception_Thrown"
    OUT_OF_MEMORY = "Insufficient_Memory"
    INTERNAL_ERROR = "Internal_Error"
    # a fit whose optimiser converged but whose answer is not usable
    FREE_RUN_FAILED = "free-run failed"
    # a simulation (free run, posterior sample)
    OK = "ok"
    BLOW_UP = "blow-up"
    TOO_STIFF = "too stiff"
    OUTSIDE_PRIOR = "outside prior"
    # a diagnosis candidate that was not fitted
    SCREENED_OUT = "screened out"
    # an outcome the producer did not recognise (its own text is kept beside it)
    UNKNOWN = "unknown"

    def __str__(self) -> str:  # print the JSON value, not "Status.OK"
        return self.value

    @classmethod
    def parse(cls, value: str | Status) -> Status:
        """The member whose value is ``value``; :attr:`UNKNOWN` for a string no member has."""
        try:
            return cls(value)
        except ValueError:
            return cls.UNKNOWN

    @property
    def success(self) -> bool:
        """Whether the outcome, on its own, gives a usable answer (a fit still has to pass its checks)."""
        return self in _SUCCESS

    @property
    def out_of_time(self) -> bool:
        """A run stopped by a time limit (its answer is the best found so far)."""
        return self in (Status.CPU_TIME, Status.IPOPT_WALL_TIME, Status.TIME_LIMIT)

    @property
    def message(self) -> str:
        """One sentence a user reads beside the status."""
        return MESSAGES.get(self, f"the run ended with status {self.value}")


_SUCCESS = frozenset({Status.SOLVED, Status.ACCEPTABLE, Status.RIDGE, Status.OK})

MESSAGES: dict[Status, str] = {
    Status.SOLVED: "IPOPT converged",
    Status.ACCEPTABLE: "IPOPT converged to its acceptable tolerance",
    Status.RIDGE: "IPOPT was stopped on a ridge: the cost no longer fell while some parameters still moved; the "
    "answer is usable, and the parameters that moved are poorly determined by the data",
    Status.MAX_ITER: "IPOPT reached its iteration limit before converging; raise max_iter or give a better start",
    Status.TIME_LIMIT: "the fit reached its time limit; the best point so far is reported, not converged",
    Status.CPU_TIME: "IPOPT reached its CPU-time limit before converging",
    Status.IPOPT_WALL_TIME: "IPOPT reached its wall-time limit before converging",
    Status.INFEASIBLE: "IPOPT found the collocation constraints locally infeasible; check the parameter bounds and "
    "the model's stability for this input",
    Status.RESTORATION_FAILED: "IPOPT's restoration phase failed; try another start or looser bounds",
    Status.INVALID_NUMBER: "IPOPT met NaN/inf in the model functions; the start or bounds allow a blow-up, tighten "
    "the bounds",
    Status.FREE_RUN_FAILED: "the optimiser converged but the free run of the fitted model fails on the record",
    Status.OK: "the run reached the end of the record",
    Status.BLOW_UP: "the state grew past the blow-up limit: the trajectory diverges",
    Status.TOO_STIFF: "the integrator needed more substeps per sample than allowed: the run is too stiff",
    Status.OUTSIDE_PRIOR: "the parameter set lies outside the prior",
    Status.SCREENED_OUT: "the candidate was screened out before its fit",
    Status.UNKNOWN: "an outcome the package does not recognise",
}
