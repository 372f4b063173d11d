"""The built wheel carries the model: install it into a fresh virtual env and load a task from there."""
import subprocess
import sys
import sysconfig
import textwrap
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheel_installs_and_loads_a_task(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                    str(tmp_path / "dist"), str(ROOT)], check=True)
    (wheel,) = (tmp_path / "dist").glob("shoulder_bench-*.whl")
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True)
    py = env_dir / "bin" / "python"
    site = subprocess.run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    # the dependencies come from this environment (read-only path entry); the package itself only from the wheel
    Path(site, "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run([py, "-m", "pip", "install", "--no-deps", "--no-index", "-q", str(wheel)], check=True)
    script = textwrap.dedent("""
        import numpy as np, shoulder_bench, gymnasium as gym
        assert "venv" in shoulder_bench.__file__, shoulder_bench.__file__
        assert shoulder_bench.MODEL_PATH.exists() and "venv" in str(shoulder_bench.MODEL_PATH)
        env = shoulder_bench.load("abduction_4m", split="test", seed=0)
        ts = env.reset()
        for _ in range(5):
            ts = env.step(np.zeros(4))
        assert np.isfinite(ts.reward)
        gym.make("ShoulderBench/abduction_ssp-v0").reset(seed=0)
        print("ok")
    """)
    out = subprocess.run([py, "-c", script], cwd=tmp_path, capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-2000:]
