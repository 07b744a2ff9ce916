"""Contract between the metrics and the validator (issue 16, "the validator by table"):
every metric a loop ``supports`` (and so every result reports) on every plant
configuration the contract cases know has a measurement declared in that plant's validator
model (:func:`feedtune.validate.block.is_measured`), or is on :data:`EXEMPT` with the
reason. A new metric module, a new plant configuration or a metric newly supported on a
loop fails here until the validator measures it.

The declarations are checked on the model the validator builds for the configuration at
its nominal tuned point, the way ``validate_result`` builds it from a result (the plant
spec as JSON, the tuned values as floats).
"""

from __future__ import annotations

import functools
import json

import pytest

from feedtune.validate.model import NotCovered

from contract_cases import (CONFIGS, OPTION_SAMPLES, exact_metric_cases, exact_nominal,
                            metric_cases, nominal)
from feedtune.validate.block import is_measured
from feedtune.validate.models import model_for

_FORMULA = ("a paper's closed form, not a property of the loop: the validator measures "
            "the exact quantity it approximates ({exact}) on the same loop, and "
            "tests/unit/test_metrics.py and tests/reference check the formula against the "
            "paper's equations and numbers")
_ARITHMETIC = ("arithmetic of the spec's constants and the tuned values the result lists "
               "({what}): there is no loop behaviour to re-simulate")
_GAP = ("the relative gap between a paper formula ({formula}) and the simulated circle "
        "test ({exact}): the circle test is measured, the formula is {side}")

#: (validator model class, metric) → why the validator does not re-measure it. Keep it
#: short: each line is a metric a result reports without an independent check.
EXEMPT: dict[tuple[str, str], str] = {
    ("ServoModel", "radial_error_koren"): _FORMULA.format(exact="radial_error"),
    ("ServoModel", "min_radius_koren"): _FORMULA.format(exact="min_radius"),
    ("ServoModel", "surface_roughness"): _FORMULA.format(exact="circle_roughness"),
    ("PadeServoModel", "surface_roughness"): _FORMULA.format(
        exact="circle_roughness, on the exact model"),
    ("ServoModel", "radius_decrease_gap"): _GAP.format(
        formula="radius_decrease, eq 7", exact="circle_mean_deviation",
        side="measured too"),
    ("ServoModel", "surface_roughness_gap"): _GAP.format(
        formula="surface_roughness, eq 10", exact="circle_roughness",
        side="a closed form (exempt above)"),
    ("ServoModel", "encoder_ratio"): _ARITHMETIC.format(what="f_m/f_s = V_m·T/BLU"),
    ("ServoModel", "sampling_ratio"): _ARITHMETIC.format(what="T/τ"),
    ("ServoModel", "counter_utilisation"): _ARITHMETIC.format(what="f_m·T/2^(bits−1)"),
    ("ServoModel", "interpolation_ratio"): _ARITHMETIC.format(what="q = T_ref/T"),
    ("PadeServoModel", "interpolation_ratio"): _ARITHMETIC.format(what="q = T_ref/T"),
    ("ServoModel", "reference_interval"): _ARITHMETIC.format(what="T_ref itself"),
    ("PadeServoModel", "reference_interval"): _ARITHMETIC.format(what="T_ref itself"),
    # not yet measured: Koren's criterion needs the loop's |H| over a scan of radii, which
    # ServoModel.min_radius runs on the exact sampled loop only
    ("PadeServoModel", "min_radius"): ("Koren's BLU/2 criterion is measured on the exact "
                                       "sampled loop (model 'exact'); the Padé stand-in's "
                                       "scan is not written yet"),
}


#: plant configurations (contract ids, prefix) the validator has no model of yet: their
#: results say ``covered: false``. Listed, not hidden: each case is an expected failure
#: (xfail) that fails outright once a model exists, so the entry must then be dropped.
UNCOVERED: dict[tuple[str, str], str] = {}


def _exempt(model, name: str) -> str | None:
    return EXEMPT.get((type(model).__name__, name))


def _model(config, tuned: dict):
    plant = config.plant.params.model_dump(mode="json")
    return model_for(plant, tuned, {"horizon": 1.0})


@functools.lru_cache(maxsize=None)
def _nominal_model(config, point):
    """:func:`_model` at ``point(config)``, built once per configuration for its ≈ 20 metric
    cases, which only ask it what it declares (``is_measured``)."""
    return _model(config, point(config))


def _uncovered(config) -> str | None:
    """Why the validator has no model of ``config`` (its UNCOVERED entry), or None."""
    return next((why for (plant, choice), why in UNCOVERED.items()
                 if config.id.startswith(plant) and choice in config.id), None)


CASES = ([(config, name, options, nominal) for config, name, options in metric_cases()]
         + [(config, name, options, exact_nominal)
            for config, name, options in exact_metric_cases()])
CASE_IDS = [f"{name}-{config.id}-{options.model_dump(mode='json')}"
            for config, name, options, _ in CASES]


@pytest.mark.parametrize("config, name, options, point", CASES, ids=CASE_IDS)
def test_every_reported_metric_has_a_validator_measurement(config, name, options, point):
    gap = _uncovered(config)
    if gap is not None:
        with pytest.raises(NotCovered):  # a model now exists: drop the UNCOVERED entry
            _model(config, point(config))
        pytest.xfail(gap)
    model = _nominal_model(config, point)
    opts = options.model_dump(mode="json")
    reason = _exempt(model, name)
    if reason is not None:
        assert not is_measured(model, name, opts), \
            f"{name} on {config.id} is measured now: drop its exemption ({reason})"
        return
    assert is_measured(model, name, opts), (
        f"{name}({opts}) is reported on {config.id} but {type(model).__name__} declares no "
        f"measurement of it: add one to its table (feedtune/validate) or an exemption "
        f"with the reason to EXEMPT")


#: configurations whose nominal result is tuned (all tunables fixed) and validated in
#: full: the sampled user loop, whose validator model is the newest (issue 16 item 6)
VALIDATED_IN_FULL = [c for c in CONFIGS if c.key == "linear" and "implementation=sampled" in c.id
                     and _uncovered(c) is None]


#: (configuration id, metric) its loop reports: a discrete drive has no intersample response,
#: so no step integral (its objective is then M_p, which every sampled loop reports)
_REPORTED = {(config.id, name) for config, name, _, _ in CASES}


@pytest.mark.parametrize("config", VALIDATED_IN_FULL, ids=[c.id for c in VALIDATED_IN_FULL])
def test_a_nominal_sampled_linear_result_is_validated_in_full(config):
    """``feedtune.tune`` at the nominal point (every tunable fixed, so the result holds the
    loop's own metrics and nothing an optimiser chose) is covered, every reported metric
    has its entry, and every entry is within its tolerance."""
    import feedtune

    plant = config.plant.params.model_dump(mode="json")
    circle = {"radius": OPTION_SAMPLES["radius"], "feed": OPTION_SAMPLES["feed"]}
    spec = {"name": "contract", "plant": plant,
            "tunables": {k: {"value": v} for k, v in nominal(config).items()},
            "objective": [{"metric": "iae" if (config.id, "iae") in _REPORTED else "m_peak"}],
            "constraints": [{"metric": "radial_error", **circle, "max": 1.0}]}
    result = json.loads(feedtune.tune(spec).to_json())
    block = result["validation"]
    assert block["covered"] and block["ok"], block
    measured = {(e["metric"], json.dumps(e["options"], sort_keys=True)) for e in block["entries"]}
    reported = {(m["metric"], json.dumps(m["options"], sort_keys=True))
                for m in result["metrics"].values() if m["value"] is not None}
    assert reported <= measured, reported - measured
