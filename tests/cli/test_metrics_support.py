"""``feedtune metrics`` says which plants and techniques support each metric, and the
unsupported-metric error of a spec lists what is supported instead.

The support table is computed by the command (each metric's ``supports`` asked on each
plant configuration's loop); these tests check it against what the spec validation, a
separate path, accepts and refuses for the bundled examples, and against the metrics'
definitions (M_s needs an open loop L(jω); ζ_min has no polynomial test on a sampled loop).
"""

from __future__ import annotations

import copy
import json
import subprocess
from pathlib import Path

import pytest

from feedtune.measured.datadriven_spec import DATA_METRICS
from feedtune.objectives import METRICS
from feedtune.schema.spec import SpecError, parse_spec

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]


def run(*args: str) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (bytes out;
    tests/feedtune_cli.py)."""
    return run_cli(*args, cwd=REPO)


@pytest.fixture(scope="module")
def table() -> dict:
    proc = run("metrics", "--json")
    assert proc.returncode == 0, proc.stderr.decode()
    return json.loads(proc.stdout)


def example(name: str) -> dict:
    return json.loads((REPO / "examples" / f"{name}.json").read_text())


def test_every_metric_lists_where_it_is_supported(table):
    assert set(table) == set(METRICS) | set(DATA_METRICS)  # DATA_METRICS: measured data only
    for name, described in table.items():
        assert described["supported"], f"{name}: supported nowhere"
        assert set(described["reported_only"]) <= set(described["supported"])


def test_support_follows_the_metric_definitions(table):
    """M_s on the loops with an open loop (the continuous cascades, Sato's Padé loop, the
    sampled-data loop's L(e^{jωT}), Koren's reference-pulse loop K/(s(1 + sτ)), issue 16);
    ζ_min everywhere but reported only on the sampled loops; σ_min
    everywhere and optimisable everywhere; pulse metrics on the pulse generator alone."""
    m_s = table["sensitivity_peak"]["supported"]
    assert any(c.startswith("hydraulic_rotary") for c in m_s)
    assert any(c.startswith("ward_leonard") for c in m_s)
    assert "software_servo(technique=sampled_data)" in m_s
    assert "software_servo(technique=reference_pulse)" in m_s
    assert "software_servo(technique=sampled_data, model=pade)" in m_s
    assert table["sensitivity_peak"]["supported"] == table["m_peak"]["supported"]
    damping = table["pole_damping"]
    assert {"software_servo(technique=sampled_data)",
            "software_servo(technique=sampled_data, interpolation=linear)"} <= set(
        damping["reported_only"])
    # reported only on sampled loops (the z-plane region is a spiral), on every one of them
    assert all("sampled" in c for c in damping["reported_only"])
    assert set(damping["supported"]) == set(table["decay_rate"]["supported"])
    assert table["decay_rate"]["reported_only"] == []
    assert {c.split("(")[0] for c in table["pulse_rise_time"]["supported"]} == {"pulse_generator"}


def _plain(name: str) -> bool:
    """A metric that can be a minimised objective term with its default options."""
    try:
        METRICS[name].Options()
    except ValueError:
        return False
    return METRICS[name].direction is None


@pytest.mark.parametrize("name", ["koren-1979-sampled-data", "koren-1979-reference-pulse",
                                  "bhatia-1971-hydraulic", "sato-table2-a"])
def test_the_table_agrees_with_what_a_spec_accepts(table, name):
    """For a bundled example, the metrics the table lists for its configuration are those
    the spec check lists as supported when a metric is refused (a metric no configuration
    of this one's label supports is refused, with the JSON pointer)."""
    from feedtune.plants import plant_for
    from feedtune.schema.spec import plant_configuration

    spec = example(name)
    label = plant_configuration(plant_for(parse_spec(spec).plant).params)
    listed = {m for m, d in table.items() if label in d["supported"]}
    refused = [m for m in sorted(set(METRICS) - listed) if _plain(m)]
    assert refused, f"{label} supports every metric without options"
    bad = copy.deepcopy(spec)
    bad["objective"] = [{"metric": refused[0]}]
    with pytest.raises(SpecError) as info:
        parse_spec(bad)
    [(pointer, message)] = info.value.errors
    assert pointer == "/objective/0/metric"
    assert f"plant configuration, {label}" in message
    assert set(message.split("supported here: ")[1].split(", ")) == listed


def test_text_output_says_supported_by(table):
    proc = run("metrics")
    assert proc.returncode == 0
    blocks = proc.stdout.decode().split("\n\n")
    by_name = {block.split(" ", 1)[0]: block for block in blocks}
    assert set(by_name) == set(METRICS) | set(DATA_METRICS)
    for name, block in by_name.items():
        assert "\n  supported by: " in block, name
    damping = by_name["pole_damping"]
    assert "software_servo(technique=sampled_data) (reported only)" in damping
    assert "hydraulic_rotary" in by_name["sensitivity_peak"]
    assert "sensitivity_peak [1]" in proc.stdout.decode()
    assert "decay_rate [1/s]" in proc.stdout.decode()
