"""`shoulder-bench render`: small headless videos decode with the expected frames, are not blank, show motion."""
import argparse

import imageio
import numpy as np
import pytest

from shoulder_bench.cli import render as render_cli
from shoulder_bench.eval import overlay, render, render_model
from shoulder_bench.eval.render import render_video

W, H = 160, 120


def _lift_csv(path):
    """30 -> 90 deg in 2 s: the arm certainly moves."""
    t = np.arange(0, 2.01, 0.1)
    a = 30 + 60 * np.clip(t / 1.5, 0, 1)
    path.write_text("time_s,angle_deg\n" + "".join(f"{x:.1f},{y:.3f}\n" for x, y in zip(t, a)))
    return path


def _mp4_frames(path):
    with imageio.get_reader(str(path), format="FFMPEG") as r:
        return [np.asarray(f) for f in r]


def _scene(frame):
    """The picture below the text and bars at the top, above the text band at the bottom."""
    return frame[H // 3: -H // 5].astype(float)


def test_mp4_frames_not_blank_and_moving(tmp_path):
    out = tmp_path / "lift.mp4"
    info = render_video(out, task="abduction_4m", trajectory=_lift_csv(tmp_path / "lift.csv"), seconds=1.5,
                        width=W, height=H, fps=20)
    assert info["path"] == str(out) and info["frames"] == 30 and not info["crashed"]
    frames = _mp4_frames(out)
    assert abs(len(frames) - 20 * 1.5) <= 1
    assert frames[0].shape == (H, W, 3)
    assert all(f.std() > 10 for f in frames)  # not blank
    moved = np.abs(_scene(frames[-1]) - _scene(frames[0])).mean()
    assert moved > 3.0, f"the arm does not move (mean pixel change {moved:.2f})"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lift.csv", "lift.mp4"]  # no temp file left


def test_gif_from_the_command_line_with_a_policy(tmp_path):
    torch = pytest.importorskip("torch")
    from shoulder_bench.train.policy import save_policy

    class Still(torch.nn.Module):
        def forward(self, obs: torch.Tensor) -> torch.Tensor:
            return torch.zeros(obs.shape[0], obs.shape[1] - 4)

    pt = save_policy(Still(), tmp_path / "still.pt", {"task": "abduction_ssp", "algo": "still"})
    parser = argparse.ArgumentParser()
    render_cli.add_parser(parser.add_subparsers())
    args = parser.parse_args(["render", "--policy", str(pt), "--out", str(tmp_path / "clip.mp4"), "--gif",
                              "--seconds", "1", "--width", str(W), "--height", str(H), "--fps", "10"])
    assert args.func(args) == 0
    gif = tmp_path / "clip.gif"  # --gif writes a GIF whatever the suffix given
    assert gif.exists() and not (tmp_path / "clip.mp4").exists()
    with imageio.get_reader(str(gif), format="GIF") as r:
        frames = [np.asarray(f)[..., :3] for f in r]
    assert abs(len(frames) - 10) <= 1
    assert frames[0].shape[:2] == (H, W) and frames[0].std() > 10


def test_bad_output_directory_is_a_clear_error_and_writes_nothing(tmp_path):
    missing = tmp_path / "no" / "such" / "dir" / "x.mp4"
    with pytest.raises(FileNotFoundError, match="does not exist.*mkdir"):
        render_video(missing, seconds=0.5, width=W, height=H)
    assert not (tmp_path / "no").exists()
    with pytest.raises(ValueError, match=r"\.mp4"):
        render_video(tmp_path / "x.avi", seconds=0.5, width=W, height=H)
    assert list(tmp_path.iterdir()) == []


def test_bad_inputs_are_clear_errors(tmp_path):
    with pytest.raises(ValueError, match="unknown task.*abduction_4m"):
        render_video(tmp_path / "x.mp4", task="abduction_4", seconds=0.5, width=W, height=H)
    with pytest.raises(FileNotFoundError, match="policy file"):
        render_video(tmp_path / "x.mp4", policy=str(tmp_path / "none.pt"), seconds=0.5, width=W, height=H)
    with pytest.raises(FileNotFoundError, match="trajectory file"):
        render_video(tmp_path / "x.mp4", trajectory=tmp_path / "none.csv", seconds=0.5, width=W, height=H)
    with pytest.raises(ValueError, match="even"):
        render_video(tmp_path / "x.mp4", seconds=0.5, width=161, height=H)
    assert list(tmp_path.iterdir()) == []


def test_failure_while_rendering_leaves_no_partial_file(tmp_path, monkeypatch):
    calls = []

    def draw(self, frame, *a):
        calls.append(1)
        if len(calls) > 3:
            raise RuntimeError("boom")
        return frame

    monkeypatch.setattr(overlay.Overlay, "draw", draw)
    with pytest.raises(RuntimeError, match="boom"):
        render_video(tmp_path / "x.mp4", seconds=1, width=W, height=H, fps=10)
    assert list(tmp_path.iterdir()) == []


def _overlay_reference(ov, frame, t, angle, target, acts, crashed):
    """The overlay as Pillow draws it on the whole frame (`Overlay.draw` before its caching): the pixels to give."""
    from PIL import Image, ImageDraw

    img = Image.fromarray(frame)
    d = ImageDraw.Draw(img, "RGBA")
    pad, s = max(3, ov.size // 3), ov.size
    text = f"t {t:5.2f} s   angle {angle:6.1f}°   target {target:6.1f}°"
    if crashed:
        text += "   CRASHED"
    d.rectangle([0, ov.height - s - 2 * pad, ov.width, ov.height], fill=(0, 0, 0, 150))
    d.text((pad, ov.height - s - pad), text, font=ov.font, fill=(255, 255, 255))
    d.text((pad, pad), ov.title, font=ov.small, fill=(255, 255, 255), stroke_width=1, stroke_fill=(0, 0, 0))
    bar_w, row = max(20, ov.width // 8), int(ov.small.size * 1.3)
    x1 = ov.width - pad - bar_w
    label_w = max(ov.small.getlength(f"{m} 00.0%") for m in ov.muscles)
    top = pad if ov.small.getlength(ov.title) + label_w + bar_w + 4 * pad < ov.width else pad + row
    for i, (name, a) in enumerate(zip(ov.muscles, acts)):
        y = top + i * row
        f = min(float(a) / ov.scale, 1.0)
        rgb = tuple(int(255 * c) for c in (render_model.PALE[:3] + f * (render_model.SATURATED[:3] -
                                                                          render_model.PALE[:3])))
        d.text((x1 - pad, y), f"{name} {100 * float(a):4.1f}%", font=ov.small, fill=(255, 255, 255),
               anchor="ra", stroke_width=1, stroke_fill=(0, 0, 0))
        d.rectangle([x1, y + 1, x1 + bar_w, y + row - 2], fill=(0, 0, 0, 120), outline=(255, 255, 255, 160))
        d.rectangle([x1, y + 1, x1 + int(round(bar_w * f)), y + row - 2], fill=rgb)
    y = top + len(ov.muscles) * row
    d.text((x1 + bar_w, y), f"bar = {100 * ov.scale:g}%", font=ov.small, fill=(220, 220, 220), anchor="ra",
           stroke_width=1, stroke_fill=(0, 0, 0))
    return np.asarray(img)


@pytest.mark.parametrize("width, height, title, muscles", [
    (480, 360, "abduction_4m · ppo (pretrained:ppo_4m)", ["ssp", "isp", "dmi", "ld"]),
    (W, H, "abduction_ssp · posterosuperior_tear+ld_transfer · reference controller", ["ssp"]),  # bars below title
    (48, 40, "track_3dof · a title wider than the frame", ["ssp", "isp", "dmi", "ld", "ams", "pms", "pec1"]),
])
def test_overlay_gives_the_pixels_of_drawing_on_the_whole_frame(width, height, title, muscles):
    """The cached overlay (static text drawn once, only the rows it covers through Pillow) is pixel for pixel Pillow's
    drawing on the whole frame: over noise, repeated labels (cache hits), zero and saturated bars, a crash, text and
    bars reaching past the frame's edges."""
    rng = np.random.default_rng(1)
    for scale in (0.05, 1.0):
        ov = overlay.Overlay(width, height, title, muscles, scale)
        for k in range(6):
            frame = rng.integers(0, 256, (height, width, 3), dtype=np.uint8)
            acts = [0.0] * len(muscles) if k == 0 else rng.uniform(0, 1, len(muscles)) * [0.01, 0.1, 1.0][k % 3]
            args = (rng.uniform(0, 99), rng.uniform(-200, 200), rng.uniform(0, 180), acts, k == 2)
            want = _overlay_reference(ov, frame.copy(), *args)
            got = ov.draw(frame, *args)
            assert got is frame  # drawn in place
            assert np.array_equal(got, want), f"{np.count_nonzero((got != want).any(-1))} pixels differ"
            if k == 5:  # the same labels again: from the cache
                frame = rng.integers(0, 256, frame.shape, dtype=np.uint8)
                want = _overlay_reference(ov, frame.copy(), *args)
                assert np.array_equal(ov.draw(frame, *args), want)
                frame = rng.integers(0, 256, frame.shape, dtype=np.uint8)
                frame.flags.writeable = False  # a read-only frame: drawn on a copy
                assert np.array_equal(ov.draw(frame, *args), _overlay_reference(ov, frame, *args))


def test_render_model_poses_arm_girdle_and_ghost_as_the_task_model():
    """The rendered arm is the simulated one (girdle on its coupling) and the ghost is the humerus at the target."""
    import mujoco

    from shoulder_bench import arm

    m = render_model.build_render_model(W, H)
    assert m.nu == 0 and {m.camera(k).name for k in range(m.ncam)} >= set(render.CAMERAS)
    d, poser, task = mujoco.MjData(m), render_model.Poser(m), arm.LockedPath()
    for elevation, target in ((0, 150), (90, 30), (150, 90)):
        poser.pose(d, np.radians(elevation), np.radians(target))
        sim = task.pose(np.radians(elevation))
        mujoco.mj_tendon(task.m, sim)
        for b in ("clavicle", "scapula", "humerus"):
            np.testing.assert_allclose(d.xpos[m.body(b).id], sim.xpos[task.m.body(b).id], atol=1e-12)
            np.testing.assert_allclose(d.xquat[m.body(b).id], sim.xquat[task.m.body(b).id], atol=1e-12)
        np.testing.assert_allclose(d.ten_length, sim.ten_length, atol=1e-12)
        at = task.pose(np.radians(target))
        hum = task.m.body("humerus").id
        np.testing.assert_allclose(d.xpos[m.body(render_model.GHOST).id], at.xpos[hum], atol=1e-12)
        np.testing.assert_allclose(d.xquat[m.body(render_model.GHOST).id], at.xquat[hum], atol=1e-12)
    ghost = m.geom("ghost_humerus")
    np.testing.assert_allclose(ghost.size, render_model.GHOST_SCALE * m.geom("humerus").size)
    assert ghost.group == m.geom("humerus").group and ghost.rgba[3] < 0.5


@pytest.mark.parametrize("task", ["abduction_4m", "abduction_ssp"])
def test_muscles_coloured_by_their_activation_ld_bundles_by_ld(tmp_path, monkeypatch, task):
    import mujoco

    seen = []
    update = mujoco.Renderer.update_scene

    def spy(self, data, *a, **k):
        seen.append({data.model.tendon(t).name: data.model.tendon_rgba[t].copy() for t in range(data.model.ntendon)})
        return update(self, data, *a, **k)

    monkeypatch.setattr(mujoco.Renderer, "update_scene", spy)
    render_video(tmp_path / "x.mp4", task=task, seconds=0.5, width=W, height=H, fps=10)
    rgba = seen[-1]
    idle = [t for t, c in rgba.items() if np.allclose(c, render_model.IDLE, atol=1e-6)]
    if task == "abduction_4m":
        assert idle == [] and np.array_equal(rgba["ld1"], rgba["ld2"]) and np.array_equal(rgba["ld1"], rgba["ld3"])
    else:
        assert idle == ["isp", "dmi", "ld1", "ld2", "ld3"]


def test_multisampling_is_off_by_default_and_an_option():
    assert render_model.build_render_model(W, H).vis.quality.offsamples == 0
    assert render_model.build_render_model(W, H, multisample=True).vis.quality.offsamples == render_model.MULTISAMPLES


def test_a_condition_renders_its_geometry_and_greys_its_removed_muscles(tmp_path, monkeypatch):
    import mujoco

    from shoulder_bench import arm

    seen = []
    update = mujoco.Renderer.update_scene

    def spy(self, data, *a, **k):
        m = data.model
        seen.append({"rgba": {m.tendon(t).name: m.tendon_rgba[t].copy() for t in range(m.ntendon)}})
        return update(self, data, *a, **k)

    monkeypatch.setattr(mujoco.Renderer, "update_scene", spy)
    info = render_video(tmp_path / "x.mp4", seconds=0.2, width=W, height=H, fps=10,
                        condition="posterosuperior_tear+ld_transfer")
    assert info["frames"] == 2
    rgba = seen[-1]["rgba"]
    idle = sorted(t for t, c in rgba.items() if np.allclose(c, render_model.IDLE, atol=1e-6))
    assert idle == ["isp", "ssp"]  # removed: grey; dmi and ld still coloured by their activations
    # the rerouted latissimus: the ld_transfer model's path, not the intact one
    rerouted = mujoco.MjModel.from_xml_path(str(arm.model_file("ld_transfer")))
    intact = mujoco.MjModel.from_xml_path(str(arm.MODEL_FILE))

    def path(m):
        t = m.tendon("ld1").id
        return [int(i) for i in m.wrap_objid[m.tendon_adr[t]:m.tendon_adr[t] + m.tendon_num[t]]]

    assert path(rerouted) != path(intact)
    model = render_model.build_render_model(W, H, geometry="ld_transfer")
    assert path(model) == path(rerouted)
    with pytest.raises(ValueError, match="unknown condition 'nope'"):
        render_video(tmp_path / "y.mp4", condition="nope")
    assert not (tmp_path / "y.mp4").exists()
