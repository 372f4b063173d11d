"""The reference controller (computed torque + static optimisation) tracks the 4-muscle task within its limits."""
import json

import numpy as np
import pytest
import torch

from shoulder_bench.cli import main
from shoulder_bench.eval.evaluate import evaluate
from shoulder_bench.eval.reference import ReferenceController
from shoulder_bench.trajectory import load_test_set


def test_reference_tracks_a_test_trajectory_with_bounded_error():
    m = evaluate(ReferenceController("abduction_4m"), "abduction_4m", load_test_set()[:3])
    assert m["crashes"] == 0 and m["mae_deg"] < 1.0 and m["rmse_deg"] < 1.5


def test_reference_respects_the_action_limits():
    c = ReferenceController("abduction_4m")
    obs = torch.tensor([[30.0, 0.0, 90.0, 200.0, 0.5, 0.0, 0.0, 1.0]])  # far from the target: saturates
    a = c(obs).numpy()[0]
    assert np.all(np.abs(a) <= 0.01 + 1e-12)
    act = obs.numpy()[0, 4:] + a
    assert np.all((act >= -1e-12) & (act <= 1 + 1e-12))


def test_reference_rejects_discrete_tasks():
    with pytest.raises(ValueError, match="continuously"):
        ReferenceController("abduction_4m_discrete")


def test_eval_reference_command(capsys):
    csv_free = ["eval", "--policy", "reference", "--trajectories", "combing", "--json"]
    assert main(csv_free) == 0
    last = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert last["task"] == "abduction_4m" and last["n_trajectories"] == 1 and last["crashes"] == 0
