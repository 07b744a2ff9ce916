"""The IPOPT options a spec may set (``solver.ipopt_options``), with IPOPT 3.14's types and
ranges.

Its own module, without postponed annotations: each option's type is built as the class is
defined, not compiled from a string into a forward reference (by ``TypedDict``) and then
evaluated (by pydantic) as in a module with ``from __future__ import annotations``: ≈ 4 M
instructions of every ``feedtune validate`` (issue 15's start-up; benchmarks/README.md).
"""

from typing import Annotated, Literal

from pydantic import ConfigDict, Field
from typing_extensions import TypedDict


def _number(description: str, **limits):
    """A real IPOPT option (JSON number) with its description [unit] and range."""
    return Annotated[float, Field(description=description, **limits)]


def _count(description: str, **limits):
    """An integer IPOPT option (a whole JSON number) with its description [unit] and range."""
    return Annotated[int, Field(description=description, **limits)]


class IpoptOptions(TypedDict, total=False):
    """The IPOPT options a spec may set: algorithmic ones, with IPOPT 3.14's types and ranges.

    Options that name a file or a library (``output_file``, ``option_file_name``,
    ``hsllib``, ``pardisolib``), choices that load a library at run time (the HSL and
    Pardiso linear solvers, MC19 scaling), output (``print_level``: stdout carries the
    result) and what ``solver`` sets itself (``max_iter``, ``tol``, ``max_wall_time``) are
    not here, so a spec cannot set them.
    """

    __pydantic_config__ = ConfigDict(extra="forbid", allow_inf_nan=False)

    hessian_approximation: Annotated[Literal["exact", "limited-memory"], Field(
        description="exact: second derivatives of the NLP; limited-memory: L-BFGS")]
    limited_memory_max_history: _count("L-BFGS history length [iterations]", ge=0, le=1000)
    limited_memory_update_type: Annotated[Literal["bfgs", "sr1"], Field(
        description="Quasi-Newton update of the limited-memory Hessian")]
    mu_strategy: Annotated[Literal["monotone", "adaptive"], Field(
        description="Barrier parameter update (Fiacco-McCormick or adaptive)")]
    mu_oracle: Annotated[Literal["probing", "loqo", "quality-function"], Field(
        description="Barrier parameter oracle of the adaptive strategy")]
    mu_init: _number("Initial barrier parameter [1, scaled problem]", gt=0)
    mu_max: _number("Largest barrier parameter, adaptive strategy [1, scaled problem]", gt=0)
    mu_min: _number("Smallest barrier parameter, adaptive strategy [1, scaled problem]", gt=0)
    nlp_scaling_method: Annotated[Literal["none", "gradient-based"], Field(
        description="Scaling of the NLP before solving")]
    nlp_scaling_max_gradient: _number("Largest gradient after gradient-based scaling [1]", gt=0)
    acceptable_tol: _number("'Acceptable' overall optimality error [1, scaled problem]", gt=0)
    acceptable_iter: _count("Successive acceptable iterates that end the solve [iterations]; "
                            "0 disables", ge=0)
    acceptable_constr_viol_tol: _number("Acceptable constraint violation [1, unscaled]", gt=0)
    acceptable_dual_inf_tol: _number("Acceptable dual infeasibility [1, unscaled]", gt=0)
    acceptable_compl_inf_tol: _number("Acceptable complementarity [1, unscaled]", gt=0)
    acceptable_obj_change_tol: _number("Acceptable relative objective change [1]", ge=0)
    constr_viol_tol: _number("Constraint violation at success [1, unscaled]", gt=0)
    dual_inf_tol: _number("Dual infeasibility at success [1, unscaled]", gt=0)
    compl_inf_tol: _number("Complementarity at success [1, unscaled]", gt=0)
    bound_push: _number("Least absolute distance of the start from a bound [1, log of the "
                        "tunable]", gt=0)
    bound_frac: _number("Least relative distance of the start from a bound [1]", gt=0, le=0.5)
    bound_relax_factor: _number("Relative relaxation of the bounds [1]; 0 disables", ge=0)
    honor_original_bounds: Annotated[Literal["yes", "no"], Field(
        description="Project the final point into the original bounds")]
    max_cpu_time: _number("CPU-time limit of one IPOPT solve [s]", gt=0)
    max_soc: _count("Second-order correction steps per iteration [count]; 0 disables", ge=0,
                    le=100)
    expect_infeasible_problem: Annotated[Literal["yes", "no"], Field(
        description="Heuristics that detect an infeasible problem early")]
    check_derivatives_for_naninf: Annotated[Literal["yes", "no"], Field(
        description="Stop on NaN/Inf in the derivative matrices")]
    linear_solver: Annotated[Literal["mumps"], Field(
        description="Linear solver: MUMPS, bundled with CasADi (the HSL and Pardiso solvers "
                    "load a library at run time and are refused)")]
    linear_system_scaling: Annotated[Literal["none", "slack-based"], Field(
        description="Scaling of the augmented linear system")]
    mumps_pivtol: _number("MUMPS pivot tolerance [1]", ge=0, le=1)
    mumps_pivtolmax: _number("Largest MUMPS pivot tolerance [1]", ge=0, le=1)
