"""feedtune.robust's pieces, each against what it must give: the first solve's scenarios,
the worst-case search on functions whose worst point is known in closed form, the
objective of groups (feedtune.tuner.scenarios), and a worst-case objective that is the
largest scenario objective."""

from __future__ import annotations

import copy
import math

import pytest

from feedtune.problem import tune
from feedtune.robust import (GRID_POINTS, ROBUST_TOL, Scenario, ScenarioSet, bound_scale,
                             initial_scenarios, margin, worst_cases)
from feedtune.schema.spec import parse_spec
from feedtune.schema.uncertainty import RobustSpec, scenario_count
from feedtune.tuner import Bound, Term
from feedtune.tuner.scenarios import objective_value


def _robust(**parameters) -> RobustSpec:
    return RobustSpec.model_validate({"parameters": parameters})


# -- scenarios -----------------------------------------------------------------------------

def test_first_scenarios_are_nominal_corners_and_interior_samples_inside_the_box():
    robust = _robust(a={"min": 1.0, "max": 2.0}, b={"values": [10.0, 20.0, 30.0]})
    scenarios = initial_scenarios(robust, {"a": 1.5, "b": 20.0})
    assert scenarios[0] == Scenario({"a": 1.5, "b": 20.0}, "nominal")
    corners = [s.values for s in scenarios if s.origin == "corner"]
    assert sorted((c["a"], c["b"]) for c in corners) == sorted(
        (a, b) for a in (1.0, 2.0) for b in (10.0, 20.0, 30.0))
    interior = [s.values for s in scenarios if s.origin == "interior"]
    assert len(interior) == robust.interior_samples == 2
    assert all(1.0 < p["a"] < 2.0 and p["b"] == 20.0 for p in interior)
    assert len(scenarios) == scenario_count(robust)  # the limit the spec checks is the count made


def test_a_corner_equal_to_the_nominal_point_is_not_repeated():
    robust = _robust(b={"values": [10.0, 20.0]})
    scenarios = initial_scenarios(robust, {"b": 10.0})
    assert [s.values["b"] for s in scenarios] == [10.0, 20.0]
    assert len(scenarios) < scenario_count(robust)  # the count is an upper bound


def test_interior_samples_are_the_same_every_time():
    robust = _robust(a={"min": 1.0, "max": 2.0}, c={"min": -1.0, "max": 1.0})
    assert initial_scenarios(robust, {"a": 1.5, "c": 0.0}) == initial_scenarios(
        robust, {"a": 1.5, "c": 0.0})


# -- margins and the worst-case search ------------------------------------------------------

def test_margin_is_the_distance_inside_the_nearer_bound():
    assert margin(1.2, None, 1.3) == pytest.approx(0.1)
    assert margin(0.6, 0.7, None) == pytest.approx(-0.1)
    assert margin(5.0, 4.0, 5.5) == pytest.approx(0.5)
    assert margin(None, 0.7, None) == -math.inf  # an unstable loop has no value: violated
    assert bound_scale(None, 1.3) == 1.3 and bound_scale(-2.0, 1.0) == 2.0
    assert bound_scale(0.0, None) == 1.0


class PeakCheck:
    """A stand-in for :class:`feedtune.robust.PointCheck`: one constraint value ≤ 1.3 whose
    value over the numbers peaks at a known interior point (a resonance moving with J)."""

    def __init__(self, peak_at: dict, height: float, sets_shift: float = 0.0):
        self.peak_at, self.height, self.shift = peak_at, height, sets_shift
        self.constraints = [(None, None, None, 1.3)]
        self.evaluations = 0

    def __call__(self, numbers, only=None):
        self.evaluations += 1
        distance = sum(((numbers[n] - v) / 0.1)**2 for n, v in self.peak_at.items())
        value = self.height / (1 + distance) + self.shift * numbers.get("s", 0.0)
        return [value], {"stable": True}


def test_the_search_finds_an_interior_worst_point_between_grid_points():
    """The peak sits between two of the 41 grid points (spacing 0.0125 over [0.5, 1]); the
    refinement's Brent (xatol 1e-6 of the range) puts it within 1e-5 of J = 0.7371, and the
    value within 1e-9 of the height (the peak is quadratic: (1e-5/0.1)² · 1.4 ≈ 1.4e-8 at
    most, measured far below)."""
    robust = _robust(j={"min": 0.5, "max": 1.0})
    check = PeakCheck({"j": 0.7371}, 1.4)
    (worst,), unstable = worst_cases(check, robust, {"j": 0.75}, [])
    assert unstable is None
    assert worst.numbers["j"] == pytest.approx(0.7371, abs=1e-5)
    assert worst.value == pytest.approx(1.4, abs=1e-8)
    assert worst.margin == pytest.approx(-0.1, abs=1e-8) and not worst.holds
    assert worst.tolerance == pytest.approx(ROBUST_TOL * 1.3)


def test_the_search_refines_two_ranges_and_holds_each_set_value():
    """Two ranges (Nelder-Mead from the best of a 15 × 15 grid) and a set {0, 1} that lifts
    the value: the worst is at the set's 1 and the peak's point, found to 1e-3 of the
    ranges (Nelder-Mead's xatol 1e-5 of the unit box)."""
    robust = _robust(j={"min": 0.5, "max": 1.0}, k={"min": 0.0, "max": 2.0},
                     s={"values": [0.0, 1.0]})
    check = PeakCheck({"j": 0.611, "k": 1.234}, 1.25, sets_shift=0.1)
    (worst,), _ = worst_cases(check, robust, {"j": 0.75, "k": 1.0, "s": 0.0}, [])
    assert worst.numbers["s"] == 1.0
    assert worst.numbers["j"] == pytest.approx(0.611, abs=1e-3)
    assert worst.numbers["k"] == pytest.approx(1.234, abs=1e-3)
    assert worst.value == pytest.approx(1.35, abs=1e-4)


class TwoChecks:
    """Two constraints ≤ 1.3 over one range j, each a peak (at 0.6 and 0.9), recording
    which constraints every evaluation computed."""

    def __init__(self):
        self.constraints = [(None, None, None, 1.3), (None, None, None, 1.3)]
        self.computed: list[tuple[int, ...]] = []

    def __call__(self, numbers, only=None):
        which = tuple(range(2)) if only is None else (only,)
        self.computed.append(which)
        peaks = [1.2 / (1 + ((numbers["j"] - at) / 0.1)**2) for at in (0.6, 0.9)]
        return [peaks[k] if k in which else None for k in range(2)], {"stable": True}


def test_the_refinement_of_a_constraint_evaluates_that_constraint_alone():
    """The sample computes every constraint; each constraint's local refinement computes
    its own only (a frequency metric's peak costs ≈ 0.1 s on Bhatia's drive): the same
    worst cases, within Brent's 1e-6 of the range."""
    robust = _robust(j={"min": 0.5, "max": 1.0})
    check = TwoChecks()
    first, second = worst_cases(check, robust, {"j": 0.75}, [])[0]
    sampled = GRID_POINTS[1]
    assert check.computed[:sampled] == [(0, 1)] * sampled
    refined = check.computed[sampled:]
    assert refined and set(refined) == {(0,), (1,)}
    assert first.numbers["j"] == pytest.approx(0.6, abs=1e-5)
    assert second.numbers["j"] == pytest.approx(0.9, abs=1e-5)
    assert first.value == pytest.approx(1.2, abs=1e-9)
    assert second.value == pytest.approx(1.2, abs=1e-9)


# -- the objective of groups ------------------------------------------------------------------

def test_objective_of_groups_is_the_largest_group_sum():
    assert objective_value([1.0, 2.0, 1.0, 2.0], [1.0, 1.0, 5.0, -1.0], [0, 0, 1, 1]) == 3.0
    assert objective_value([1.0, 1.0], [2.0, 3.0], [0, 0]) == 5.0  # one group: the sum
    assert objective_value([1.0], [None], [0]) is None


def test_scenario_set_puts_every_constraint_on_every_scenario_and_the_worst_case_objective():
    scenarios = [Scenario({"t": 1.0}, "nominal"), Scenario({"t": 2.0}, "corner")]
    nominal = ScenarioSet(scenarios, "nominal")
    worst = ScenarioSet(scenarios, "worst_case")
    terms = [Term("iae", lambda loop: loop, 1.0)]
    bounds = [Bound("zeta", lambda loop: loop, 0.5, None), Bound("m", lambda loop: loop, None, 2)]
    assert [t.group for t in nominal.terms(terms)] == [0]
    assert [t.group for t in worst.terms(terms)] == [0, 1]
    assert len(nominal.bounds(bounds)) == 4
    assert nominal.numbers() == {"scenario1.t": 2.0}

    class Loops:
        loops = ["nominal", "scenario 1"]

    assert [b.value(Loops) for b in nominal.bounds(bounds)] == [
        "nominal", "nominal", "scenario 1", "scenario 1"]


# -- the worst-case objective end to end -----------------------------------------------------

#: Koren's reference-pulse loop, minimum radial error on his 8 mm circle at 40 mm/s, with τ
#: anywhere in 10-20 ms: each τ alone has zero error at K = (1 + (ωτ)²)/(2τ), 50.1 1/s at
#: 10 ms and 25.3 1/s at 20 ms, so no K is best for every τ
SERVO = {"name": "robust-servo",
         "plant": {"type": "software_servo", "technique": "reference_pulse",
                   "time_constant": {"min": 0.010, "max": 0.020}, "blu": 5e-6,
                   "max_velocity": 0.04},
         "tunables": {"position_gain": {"min": 1, "max": 200}},
         "objective": [{"metric": "radial_error", "radius": 0.008, "feed": 0.04}],
         "solver": {"multistart": 1}}


def _radial_errors(result, taus) -> list[float]:
    """The validator's radial error of the tuned design at each τ (its own model)."""
    from feedtune.validate.models import model_for

    plant = result.spec["plant"]
    gain = {"position_gain": result.tuned["position_gain"].value}
    return [model_for({**plant, "time_constant": tau}, gain).radial_error(0.008, 0.04)
            for tau in taus]


def test_the_worst_case_objective_is_the_largest_scenario_objective_and_beats_nominal():
    """The worst-case design's objective is the largest radial error over its scenarios as
    the validator re-measures them (to 1e-12 m, far below the 5 µm BLU). It is a minimax
    design: the errors at τ = 10 and 20 ms, which K moves in opposite directions, are
    equal (measured 1.2e-12 m apart; asserted to 1e-10 m, BLU/50 000), while the
    nominal-objective design (zero error at 15 ms) leaves them 2e-7 m apart and its worst
    larger (by 7e-8 m measured; asserted by more than 1e-9 m, BLU/5000, far above the
    solver's 1e-12 m)."""
    nominal = tune(parse_spec(copy.deepcopy(SERVO)))
    worst = tune(parse_spec({**copy.deepcopy(SERVO), "robust": {"objective": "worst_case"}}))
    assert nominal.success and worst.success
    taus = [s.parameters["time_constant"] for s in worst.robust.scenarios]
    assert taus[1:3] == [0.010, 0.020]  # the corners follow the nominal scenario
    assert worst.robust.objective == "worst_case"
    worst_errors, nominal_errors = _radial_errors(worst, taus), _radial_errors(nominal, taus)
    assert worst.objective == pytest.approx(max(worst_errors), abs=1e-12)
    assert worst_errors[1] == pytest.approx(worst_errors[2], abs=1e-10)
    assert abs(nominal_errors[1] - nominal_errors[2]) > 1e-7
    assert max(worst_errors) < max(nominal_errors) - 1e-9
    assert nominal.metrics["radial_error"].value < 1e-12  # zero error at the nominal τ


# -- what a robust tuning computes once --------------------------------------------------------

def test_a_robust_tuning_validates_once_and_reuses_the_searched_scenarios(monkeypatch):
    """Each round's result is replaced by the next round's, so only the last, with its
    scenarios and worst cases, is validated (one validation however many rounds); its
    scenario rows are the last search's evaluations of the same design (one PointCheck a
    round, none more for the result), and equal a fresh evaluation of each scenario, bit
    for bit."""
    import feedtune.problem as problem
    import feedtune.robust as robust

    validations, checks = [], []
    validate = problem._validation
    init = robust.PointCheck.__init__
    monkeypatch.setattr(problem, "_validation",
                        lambda result: validations.append(result) or validate(result))

    def counted(self, *args, **kwargs):
        checks.append(self)
        init(self, *args, **kwargs)

    monkeypatch.setattr(robust.PointCheck, "__init__", counted)
    spec = copy.deepcopy(SERVO)
    spec["constraints"] = [{"metric": "damping_ratio", "min": 0.7}]
    result = tune(parse_spec(spec))
    assert result.success and result.robust.converged and result.validation["ok"]
    assert len(validations) == 1 and validations[0].robust is not None
    assert len(checks) == result.robust.rounds
    monkeypatch.setattr(robust.PointCheck, "__init__", init)
    fresh = robust.PointCheck(parse_spec(spec), {"position_gain":
                                                 result.tuned["position_gain"].value})
    for scenario in result.robust.scenarios:
        values, stability = fresh(scenario.parameters)
        assert scenario.constraints == values and scenario.stable == stability["stable"]
