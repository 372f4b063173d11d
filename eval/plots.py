"""`shoulder-bench plot curves RUN... --out FILE.png`: training curves from runs' TensorBoard logs (paper Figs. 2, 4):
mean episode return of recent training episodes and test-set MAE against frames, one line per run."""
from __future__ import annotations

import json
from pathlib import Path

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def add_parser(sub) -> None:
    p = sub.add_parser("plot", help="figures")
    what = p.add_subparsers(dest="figure", required=True, metavar="FIGURE")
    c = what.add_parser("curves", help="reward and test-MAE curves of training runs")
    c.add_argument("runs", nargs="+", type=Path, help="run folders (runs/<task>/<algo>/<seed>)")
    c.add_argument("--out", type=Path, default=Path("curves.png"))
    c.set_defaults(func=_curves)


def scalars(run: Path, tag: str) -> tuple[list[int], list[float]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    tb = Path(run) / "tb"
    if not tb.is_dir():
        raise FileNotFoundError(f"{run} has no tb/ folder: not a shoulder-bench run")
    acc = EventAccumulator(str(tb), size_guidance={"scalars": 0})
    acc.Reload()
    if tag not in acc.Tags()["scalars"]:
        return [], []
    events = acc.Scalars(tag)
    return [e.step for e in events], [e.value for e in events]


def plot_curves(runs: list[Path], out: Path) -> Path:
    fig, (ax_r, ax_e) = plt.subplots(1, 2, figsize=(11, 4))
    for run in runs:
        cfg = json.loads((Path(run) / "config.json").read_text())
        label = f"{cfg['algo']} {cfg['task']} seed {cfg['seed']}"
        ax_r.plot(*scalars(run, "train/mean_return"), label=label)
        ax_e.plot(*scalars(run, "test/mae_deg"), marker="o", label=label)
    ax_r.set(xlabel="frames", ylabel="mean episode return (recent training episodes)", title="training reward")
    ax_e.axhline(5.15, color="gray", ls="--", lw=1, label="paper PPO-4 (their model)")
    ax_e.set(xlabel="frames", ylabel="test-set MAE (deg)", title="fixed test set (100 trajectories)", yscale="log")
    for ax in (ax_r, ax_e):
        ax.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda x, _: f"{x / 1e6:g} M"))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def _curves(args) -> int:
    print(plot_curves(args.runs, args.out))
    return 0
