"""The shipped agents still reach the metrics they recorded (a guard against upgrades silently breaking them)."""
import json

import numpy as np
import pytest

from shoulder_bench.cli import main
from shoulder_bench.eval.evaluate import evaluate
from shoulder_bench.tasks import fixed_test_set
from shoulder_bench.train.policy import load_policy, pretrained_dir

AGENTS = ["ppo_ssp", "dqn_ssp", "ppo_4m", "bdq_4m", "ppo_track_3dof", "bdq_track_3dof"]
SUBSET = 10  # trajectories of the fixed test set


@pytest.mark.parametrize("name", AGENTS)
def test_pretrained_agent_meets_its_recorded_metrics(name):
    record = json.loads((pretrained_dir() / f"{name}.json").read_text())
    policy, meta = load_policy(f"pretrained:{name}")
    m = evaluate(policy, meta["task"], fixed_test_set(meta["task"])[:SUBSET], muscle_model=meta["muscle_model"])
    recorded = np.array(record["per_trajectory_mae_deg"][:SUBSET])
    np.testing.assert_allclose(m["per_trajectory"]["mae_deg"], recorded, atol=0.05)


def test_unknown_pretrained_name_lists_the_shipped_ones(capsys):
    assert main(["eval", "--policy", "pretrained:nope"]) == 2
    assert "ppo_4m" in capsys.readouterr().err
