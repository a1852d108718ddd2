"""Helpers of benchmarks/bench_plan.py (no planning here)."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from benchmarks import bench_plan as b


def _parser() -> argparse.ArgumentParser:
    return argparse.ArgumentParser(prog="bench_plan.py")


def test_parse_params_numbers_and_words():
    out = b._parse_params(_parser(), ["mutation_rate=0.3", "m_power=1", "acceptance=always"])
    assert out == {"mutation_rate": 0.3, "m_power": 1.0, "acceptance": "always"}


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("mutation_rate", "expected KEY=VALUE"),
        ("foo=1", "unknown parameter 'foo'"),
        ("mutation_rate=2", "mutation_rate must be"),
        ("acceptance=sometimes", "acceptance"),
    ],
)
def test_parse_params_rejects_bad_items(item, message, capsys):
    with pytest.raises(SystemExit) as e:
        b._parse_params(_parser(), [item])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "--ampso" in err and message in err


def test_bootstrap_counts_samples_where_ampso_wins():
    rng = np.random.default_rng(1)
    other = 0.6 + 0.05 * rng.standard_normal(40)
    # AMPSO better and tighter in every run: every 10-run sample shows it
    best = 0.4 + 0.001 * rng.standard_normal(40)
    row = b._bootstrap("m", {"ampso": best, "apso": other})
    assert row[1] == "mean 1.00, mean and spread 1.00"
    # lower mean but wider spread in every sample: mean always, both never
    wide = np.where(np.arange(40) % 2 == 0, 0.2, 0.5)
    row = b._bootstrap("m", {"ampso": wide, "apso": np.full(40, 0.6)})
    assert row[1] == "mean 1.00, mean and spread 0.00"
    # worse everywhere: never
    row = b._bootstrap("m", {"ampso": other + 1.0, "apso": other})
    assert row[1] == "mean 0.00, mean and spread 0.00"


def test_within_counts_runs_near_the_best_of_all_algorithms():
    costs = {"ampso": np.array([0.50, 0.505, 0.52]), "pso": np.array([0.51, 0.60])}
    name, value, target = b._within("m", costs)
    assert name == "m / runs within 2 % of the best run (0.5000)"
    # 0.51 = +2.0 % counts (<=), 0.52 = +4 % does not
    assert value == "ampso 2/3 (worst +4.0 %), pso 1/2 (worst +20.0 %)"
    assert target == "every run (issue 20)"
