"""The status vocabulary, in one place (as cvxpy's ``settings.py``): what a result's
``status`` may say, what a batch row may say besides, and which statuses count as solved.

Each vocabulary is one ``Literal`` (what pydantic validates and ``feedtune schema``
shows); the names below are unpacked from it, so a status is written once. The solver's
own word (IPOPT's ``Solve_Succeeded`` …) stays in ``return_status``, mapped to these by
:data:`feedtune.tuner.types.STATUS`. Imports nothing: a batch's parent process reads it.
"""

from typing import Literal, get_args

#: a TuneResult's status
Status = Literal["optimal", "acceptable", "infeasible", "iteration_limit", "time_limit", "error"]
OPTIMAL, ACCEPTABLE, INFEASIBLE, ITERATION_LIMIT, TIME_LIMIT, ERROR = get_args(Status)

#: the statuses of a solved tuning (its constraints may still be violated: see ``success``)
SOLVED = (OPTIMAL, ACCEPTABLE)

#: what a batch row's status may be besides a TuneResult's: the spec cannot be used, its
#: result already exists, its worker died, it ran out of time, the batch never reached it
BatchStatus = Literal["invalid", "resumed", "worker_died", "timeout", "not_run"]
INVALID, RESUMED, WORKER_DIED, TIMEOUT, NOT_RUN = get_args(BatchStatus)

#: how a point of a design chart that was not tuned starts its status ("skipped: why")
SKIPPED = "skipped"
