import os

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture
def interrupt_after_one_block(monkeypatch):
    """A function that makes the band builds solve 3 poses a block (`bands.SAVE_EVERY`) and `bands.solve_poses` raise
    KeyboardInterrupt after its first block; it returns (the block sizes solved, the real solve_poses)."""
    def install():
        from shoulder_bench.authoring.fem import bands

        monkeypatch.setattr(bands, "SAVE_EVERY", 3)
        solved, real = [], bands.solve_poses

        def interrupted(t, poses, *a, **k):
            if solved:
                raise KeyboardInterrupt
            solved.append(len(poses))
            return real(t, poses, *a, **k)
        monkeypatch.setattr(bands, "solve_poses", interrupted)
        return solved, real
    return install
