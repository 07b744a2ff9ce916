"""One spelling of a metric with its options (feedtune.schema.labels.metric_label), used by the
result's keys, the summary, the report, validation warnings and the tuner's bound names."""

from feedtune.api import Result
from feedtune.problem import tune
from feedtune.schema.labels import metric_label
from feedtune.schema.spec import parse_spec


def test_label_spelling():
    assert metric_label("iae") == "iae" and metric_label("iae", {}) == "iae"
    assert metric_label("iae", {"time": "absolute", "input": "ramp"}) == \
        "iae(time=absolute,input=ramp)"


def test_summary_names_constraints_as_the_result_keys_its_metrics():
    spec = parse_spec({
        "name": "labels", "plant": {"type": "software_servo", "technique": "sampled_data",
                                    "time_constant": 0.02},
        "tunables": {"position_gain": {"min": 5, "max": 50},
                     "sampling_period": {"value": 0.005}},
        "objective": [{"metric": "iae"}],
        "constraints": [{"metric": "ise", "time": "natural", "max": 10.0}]})
    result = Result(tune(spec))
    key = "ise(time=natural,input=step)"
    assert key in result.metrics
    assert f"  {key} = " in result.summary()
