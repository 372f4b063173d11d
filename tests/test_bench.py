"""`shoulder-bench bench`: the batched rows are measured over one training episode, so every copy resets inside."""
import json

from shoulder_bench.cli import main


def test_bench_quick_window_includes_every_copys_reset(capsys):
    assert main(["bench", "--quick", "--json"]) == 0
    lines = capsys.readouterr().out.splitlines()
    result = json.loads(lines[-1])
    assert [r["num_envs"] for r in result["rows"]] == [16, 64]
    for r in result["rows"]:
        assert r["window_frames"] == 100 and r["resets"] == r["num_envs"]  # one reset per copy, no more
        assert r["batched_fps"] > 0 and r["bare_fps"] > 0 and r["bare_same_states_fps"] > 0
        assert abs(r["ratio_same_states"] - r["batched_fps"] / r["bare_same_states_fps"]) < 1e-9
    assert any(line.startswith("window: 100 frames") for line in lines)
    assert any(line.split()[:1] == ["64"] and line.split()[-1] == "64" for line in lines)  # the resets column
