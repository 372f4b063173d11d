"""`shoulder-bench sweep`: train a grid of tasks x algorithms x seeds, on a local process pool or a Ray cluster.

Every run is `shoulder-bench train ... --resume` in its own process, with its output in `<run>/train.log`, so one
crashing run cannot take the others down and its log says why. Runs land in `<out>/<task>/<algo>/<seed>/` (what
`shoulder-bench leaderboard --runs <out>` reads). A finished run (metrics.json with at least the frames asked for) is
skipped, and an interrupted one continues from its checkpoint, so a sweep is resumed by running it again. A failed run
is reported with the end of its log and makes the sweep exit non-zero; the other runs still finish.

On Ray (`--ray ADDRESS`; `local` starts a private local instance, `auto` joins the cluster this machine is in, or
`ray://HOST:10001` connects a client) each run executes on a worker in a temporary folder: the run folder travels
there (so an interrupted run resumes) and back, so the driver needs no shared file system. Workers need shoulder-bench
installed, e.g. `pip install "shoulder-bench[ray]"` in the cluster's image.
"""
from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LOG = "train.log"
SUMMARY = "sweep.json"
LOG_TAIL = 20  # lines of a failed run's log in the report


@dataclasses.dataclass(frozen=True)
class Job:
    task: str
    algo: str
    seed: int
    frames: int
    eval_every: int
    config: str | None = None  # JSON text of the algorithm's config overrides

    @property
    def name(self) -> str:
        return f"{self.task}/{self.algo}/{self.seed}"

    def plan(self) -> dict:
        """The run's config.json as `shoulder-bench train` will write it (checks every value)."""
        from shoulder_bench.train.plan import plan

        overrides = json.loads(self.config) if self.config is not None else {}
        return plan(self.task, self.algo, self.frames, self.seed, overrides, source=f"--config {self.algo}")[2]

    def command(self, out: Path) -> list[str]:
        cmd = [sys.executable, "-m", "shoulder_bench.cli", "train", "--task", self.task, "--algo", self.algo,
               "--seed", str(self.seed), "--frames", str(self.frames), "--eval-every", str(self.eval_every),
               "--out", str(out), "--resume"]
        if self.config is not None:
            path = out / "sweep_config.json"
            path.write_text(self.config)
            cmd += ["--config", str(path)]
        return cmd


def grid(tasks, algos, seeds, frames: int | None = None, eval_every: int = 100_000,
         configs: dict[str, str] | None = None) -> tuple[list[Job], list[str]]:
    """(jobs, skipped pairs): every fitting task x algo pair with every seed; every run's definition is checked
    (`train.plan.plan`) before any starts."""
    from shoulder_bench.tasks import check_name
    from shoulder_bench.train.plan import ALGOS, DEFAULT_FRAMES, check_task

    configs = configs or {}
    tasks = [check_name(t) for t in tasks]  # unknown names: KeyError listing the tasks
    bad = sorted(set(algos) - set(ALGOS))
    if bad:
        raise ValueError(f"unknown algorithm(s) {bad}; choose from {', '.join(ALGOS)}")
    if not seeds or len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds {seeds}: give distinct seeds")
    if frames is not None and frames <= 0:
        raise ValueError(f"--frames {frames}: give a positive budget")
    if eval_every <= 0:
        raise ValueError(f"--eval-every {eval_every}: give a positive number of frames")
    unused = sorted(set(configs) - set(algos))
    if unused:
        raise ValueError(f"--config given for {unused}, which are not in --algos {algos}")
    jobs, skipped = [], []
    for task in dict.fromkeys(tasks):
        for algo in dict.fromkeys(algos):
            try:
                check_task(task, algo)
            except ValueError:
                skipped.append(f"{task} x {algo}")
                continue
            jobs += [Job(task, algo, s, frames or DEFAULT_FRAMES[algo], eval_every, configs.get(algo)) for s in seeds]
    if not jobs:
        raise ValueError(f"no task in {tasks} fits an algorithm in {algos} (ppo: continuous tasks; dqn: discrete "
                         f"single-muscle; bdq: discrete)")
    for job in jobs:
        job.plan()  # a bad config value or seed: ValueError now, not in every run's log
    return jobs, skipped


def read_configs(items: list[str]) -> dict[str, str]:
    """{algo: JSON text} from ALGO=FILE items; the field names are checked now, the values by `grid`."""
    from shoulder_bench.train.config import read_overrides
    from shoulder_bench.train.plan import ALGOS, algo_module

    out = {}
    for item in items:
        algo, sep, path = item.partition("=")
        if not sep or algo not in ALGOS:
            raise ValueError(f"--config {item!r}: write ALGO=FILE with ALGO one of {', '.join(ALGOS)}, "
                             f"e.g. ppo=ppo.json")
        out[algo] = json.dumps(read_overrides(Path(path), algo_module(algo)[1]))
    return out


def is_finished(job: Job, root: Path) -> bool:
    from shoulder_bench.train.plan import finished_metrics

    return finished_metrics(root / job.name, job.plan()) is not None


def _die_with_parent() -> None:  # in the child, before exec: SIGTERM when the sweep dies, even by kill -9 (Linux)
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


class Child:
    """One run's `shoulder-bench train` process, in its own session (the sweep alone decides when it stops),
    logging to `<run>/train.log`."""

    def __init__(self, job: Job, folder: Path):
        folder.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ, PYTHONUNBUFFERED="1", TQDM_MININTERVAL="10")  # a progress line every 10 s in the log
        cmd = job.command(folder)
        self.folder, self.t0 = folder, time.perf_counter()
        self.log = (folder / LOG).open("a")
        self.log.write(f"$ {' '.join(cmd)}\n")
        self.log.flush()
        self.proc = subprocess.Popen(cmd, stdout=self.log, stderr=subprocess.STDOUT, env=env,
                                     stdin=subprocess.DEVNULL, start_new_session=True, preexec_fn=_die_with_parent)

    def result(self) -> dict:
        """{"rc", "wall_s", "metrics" or None} of the finished process."""
        rc = self.proc.wait()
        self.log.close()
        metrics_path = self.folder / "metrics.json"
        metrics = json.loads(metrics_path.read_text()) if rc == 0 and metrics_path.exists() else None
        return {"rc": rc, "wall_s": round(time.perf_counter() - self.t0, 1), "metrics": metrics}

    def stop(self, grace_s: float = 10.0) -> None:
        """SIGTERM to the run's process group, SIGKILL after `grace_s`."""
        for sig, wait in ((signal.SIGTERM, grace_s), (signal.SIGKILL, 5.0)):
            if self.proc.poll() is not None:
                break
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, sig)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(wait)
        self.log.close()


def run_job(job: Job, folder: Path) -> dict:
    """Train `job` in a child process writing to `folder`; {"rc", "wall_s", "metrics" or None}."""
    child = Child(job, folder)
    try:
        return child.result()
    finally:
        child.stop()


# --- Ray: each run in a worker's temporary folder, the run folder shipped both ways -----------------------------------
def pack(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()} \
        if folder.is_dir() else {}


def unpack(files: dict[str, bytes], folder: Path) -> None:
    for rel, data in files.items():
        path = folder / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".part")
        tmp.write_bytes(data)
        os.replace(tmp, path)


def run_job_remote(job: Job, files: dict[str, bytes]) -> tuple[dict, dict[str, bytes]]:
    """On a Ray worker: unpack the run folder, train, return the result and the folder's files."""
    with tempfile.TemporaryDirectory(prefix="shoulder_bench_") as tmp:
        folder = Path(tmp) / "run"
        unpack(files, folder)
        result = run_job(job, folder)
        return result | {"host": os.uname().nodename}, pack(folder)


def _ray_results(jobs: list[Job], root: Path, address: str, cpus_per_run: float):
    try:
        import ray
    except ModuleNotFoundError:
        raise ValueError('--ray needs Ray: pip install "shoulder-bench[ray]"') from None
    kwargs = {"address": address, "log_to_driver": False}
    if address == "local":
        kwargs["include_dashboard"] = False
    try:
        ray.init(**kwargs)
    except Exception as exc:  # ConnectionError, a bad address, a version mismatch ...
        raise ValueError(f"--ray {address}: could not start or join Ray ({exc})") from exc
    pending = {}
    try:
        available = ray.cluster_resources().get("CPU", 0)
        cpus = min(cpus_per_run, available) if available else cpus_per_run  # a 1-CPU node still takes runs
        remote = ray.remote(num_cpus=cpus, max_retries=0)(run_job_remote)
        pending = {remote.remote(job, pack(root / job.name)): job for job in jobs}
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            job = pending.pop(done[0])
            try:
                result, files = ray.get(done[0])
                unpack(files, root / job.name)
            except Exception as exc:  # the worker died or could not run the job
                (root / job.name).mkdir(parents=True, exist_ok=True)
                with (root / job.name / LOG).open("a") as log:
                    log.write(f"Ray task failed: {exc!r}\n")
                result = {"rc": -1, "wall_s": None, "metrics": None}
            yield job, result
    finally:
        for ref in pending:  # interrupted: kill the workers (their training children get SIGTERM as they die)
            ray.cancel(ref, force=True)
        ray.shutdown()


def _local_results(jobs: list[Job], root: Path, workers: int, running: dict):
    """Up to `workers` runs at once, each a child process watched from this thread; `running` holds the live ones."""
    queue = list(jobs)
    while queue or running:
        while queue and len(running) < workers:
            job = queue.pop(0)
            running[job] = Child(job, root / job.name)
        finished = [job for job, child in running.items() if child.proc.poll() is not None]
        for job in finished:
            yield job, running.pop(job).result()
        if not finished:
            time.sleep(0.2)


def sweep(jobs: list[Job], root: Path, workers: int | None = None, ray_address: str | None = None,
          cpus_per_run: float = 2.0, progress: bool = True) -> list[dict]:
    """Run the unfinished jobs; returns one record per job (status done, skipped or failed) and writes sweep.json.

    Ctrl-C (or SIGTERM, which the CLI turns into the same KeyboardInterrupt) stops every running child and starts no
    more: sweep.json and the printed report then list the runs as done, failed, interrupted or not started, and the
    KeyboardInterrupt propagates. Interrupted runs continue from their checkpoints when the sweep is run again."""
    from tqdm import tqdm

    from shoulder_bench.train.run import write_json

    root = Path(root)
    if root.exists() and not root.is_dir():
        raise ValueError(f"--out {root} is a file; give a folder for the sweep")
    if workers is not None and workers < 1:
        raise ValueError(f"--workers {workers}: give at least 1")
    root.mkdir(parents=True, exist_ok=True)
    records = {job: {"run": job.name, "status": "skipped (finished)"} for job in jobs if is_finished(job, root)}
    todo = [job for job in jobs if job not in records]
    workers = workers or max(1, (os.cpu_count() or 2) // 2)
    where = f"Ray ({ray_address})" if ray_address else f"{workers} local worker(s)"
    print(f"sweep: {len(jobs)} runs, {len(records)} already finished, {len(todo)} to train on {where} -> {root}")
    running: dict[Job, Child] = {}
    if not todo:
        results = iter(())
    elif ray_address:
        results = _ray_results(todo, root, ray_address, cpus_per_run)
    else:
        results = _local_results(todo, root, workers, running)
    try:
        with tqdm(total=len(todo), desc="sweep", unit="run", disable=not progress or not todo) as bar:
            for job, result in results:
                ok = result["rc"] == 0 and result["metrics"] is not None
                records[job] = {"run": job.name, "status": "done" if ok else "failed", "rc": result["rc"],
                                "wall_s": result["wall_s"], "log": str(root / job.name / LOG)}
                if ok:
                    records[job] |= {"mae_deg": result["metrics"]["mae_deg"],
                                     "rmse_deg": result["metrics"]["rmse_deg"]}
                if "host" in result:
                    records[job]["host"] = result["host"]
                bar.update()
                bar.write(f"{job.name}: " + (f"MAE {result['metrics']['mae_deg']:.2f} deg" if ok
                                             else f"FAILED (exit {result['rc']}), log {root / job.name / LOG}"))
    except KeyboardInterrupt:
        print("\nsweep interrupted: stopping the running runs ...", file=sys.stderr, flush=True)
        for child in running.values():
            child.stop()
        getattr(results, "close", lambda: None)()  # Ray: cancels the pending runs and shuts down
        for job in todo:
            if job not in records:
                was_running = job in running or ray_address is not None
                records[job] = {"run": job.name, "status": "interrupted" if was_running else "not started",
                                "log": str(root / job.name / LOG)}
        write_json(root / SUMMARY, [records[job] for job in jobs])
        print(report([records[job] for job in jobs]), file=sys.stderr)
        raise
    out = [records[job] for job in jobs]
    write_json(root / SUMMARY, out)
    return out


def report(records: list[dict]) -> str:
    lines = []
    for r in records:
        extra = f"MAE {r['mae_deg']:.2f} deg, RMSE {r['rmse_deg']:.2f} deg" if "mae_deg" in r else ""
        lines.append(f"{r['run']:<40} {r['status']:<20} {extra}")
    for r in (r for r in records if r["status"] == "failed"):
        log = Path(r["log"])
        tail = log.read_text(errors="replace").splitlines()[-LOG_TAIL:] if log.exists() else ["(no log)"]
        lines += ["", f"--- {r['run']} failed (exit {r['rc']}); last lines of {log}:"] + [f"  {x}" for x in tail]
    return "\n".join(lines)


