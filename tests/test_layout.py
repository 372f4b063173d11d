"""The layout says what is what (issue 11 §6): imports flow one way, no module reaches into another's private names,
no file is long.

Layers, lowest first; a module may import its own layer and the ones below it, never one above:
  runtime    shoulder_bench.* (model, muscle, arm, simulator, trajectory, ...): what runs an episode
  tasks      shoulder_bench.tasks.* (the single env, the batched env, gymnasium)
  train      shoulder_bench.train.*
  eval       shoulder_bench.eval.* (evaluate, leaderboard, plots, render, sweep, reproduce, bench, experiment)
  cli        shoulder_bench.cli.* (argument parsing, one module per command group)
`shoulder_bench.authoring.*` (anatomy, MJCF writers, Hill and FEM builders, validation) makes the shipped files: it
may import the runtime and itself, only the CLI imports it, and the runtime never does. The package's
`__init__` is the public facade (`shoulder_bench.load`, `make_vec`, ...): it counts as the tasks layer.
Every import counts, also one inside a function. Tests and benchmarks may use anything.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"shoulder_bench": "shoulder_bench", "tasks": "shoulder_bench.tasks", "train": "shoulder_bench.train",
            "eval": "shoulder_bench.eval"}
LEVEL = {"runtime": 0, "tasks": 1, "train": 2, "eval": 3, "cli": 4}
MAX_LINES = 420


def layer(module: str) -> str:
    parts = module.split(".")
    if parts == ["shoulder_bench"]:
        return "tasks"  # the facade
    sub = parts[1]
    return sub if sub in ("tasks", "train", "eval", "cli", "authoring", "models") else "runtime"


def allowed(importer: str, imported: str) -> bool:
    a, b = layer(importer), layer(imported)
    if "models" in (a, b):
        return True  # data and the reference scripts
    if a == "authoring":
        return b in ("runtime", "authoring")
    if b == "authoring":
        return a == "cli"
    return LEVEL[b] <= LEVEL[a]


def modules() -> dict[str, Path]:
    """module name -> file, for every module of the four package folders."""
    out = {}
    for folder, package in PACKAGES.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT / folder).with_suffix("").parts
            if rel[-1] == "__init__":
                rel = rel[:-1]
            out[".".join((package, *rel))] = path
    return out


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def check_source(name: str, source: str, is_package: bool, known: set[str]) -> list[str]:
    """The layering and private-name violations of module `name` (source text), as readable lines."""
    problems = []
    bound = {}  # local name -> the shoulder_bench module it is bound to

    def check(target: str, line: int) -> None:
        if not allowed(name, target):
            problems.append(f"{name}:{line}: {layer(name)} module imports {target} ({layer(target)})")

    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "shoulder_bench":
                    check(a.name, node.lineno)
                    bound[a.asname or a.name.split(".")[0]] = a.name if a.asname else "shoulder_bench"
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_package else name.split(".")[:-1]
                base = base[:len(base) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            if module.split(".")[0] != "shoulder_bench":
                continue
            for a in node.names:
                full = f"{module}.{a.name}"
                if full in known:  # a submodule: `from shoulder_bench import arm`
                    check(full, node.lineno)
                    bound[a.asname or a.name] = full
                else:
                    check(module, node.lineno)
                    if _private(a.name) and module != name:
                        problems.append(f"{name}:{node.lineno}: imports the private {a.name} from {module}")
    for node in ast.walk(ast.parse(source)):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound
                and _private(node.attr) and bound[node.value.id] != name):
            problems.append(f"{name}:{node.lineno}: uses the private {bound[node.value.id]}.{node.attr}")
    return problems


def test_imports_flow_one_way_and_private_names_stay_private():
    known = set(modules())
    problems = [p for name, path in modules().items()
                for p in check_source(name, path.read_text(), path.name == "__init__.py", known)]
    assert problems == [], "\n".join(problems)


def test_no_file_is_long():
    lines = {str(p.relative_to(ROOT)): len(p.read_text().splitlines()) for p in modules().values()}
    long = {p: n for p, n in lines.items() if n > MAX_LINES}
    assert long == {}, f"over {MAX_LINES} lines: {long}"


KNOWN = {"shoulder_bench.arm", "shoulder_bench.tasks", "shoulder_bench.eval.evaluate", "shoulder_bench.authoring.mobl",
         "shoulder_bench.cli", "shoulder_bench.train.ppo"}


@pytest.mark.parametrize("name, source", [
    ("shoulder_bench.arm", "from shoulder_bench.authoring import mobl\n"),  # runtime -> authoring
    ("shoulder_bench.arm", "def f():\n    from shoulder_bench.tasks import load\n"),  # runtime -> tasks, lazily
    ("shoulder_bench.tasks.x", "import shoulder_bench.train.ppo\n"),  # tasks -> train
    ("shoulder_bench.train.x", "from shoulder_bench.eval import evaluate\n"),  # train -> eval
    ("shoulder_bench.eval.x", "from shoulder_bench.cli import main\n"),  # eval -> cli
    ("shoulder_bench.eval.x", "from shoulder_bench.authoring.mobl import model_xml\n"),  # eval -> authoring
    ("shoulder_bench.authoring.x", "from shoulder_bench.tasks import load\n"),  # authoring -> tasks
    ("shoulder_bench.eval.x", "from shoulder_bench.tasks import _check\n"),  # a private name
    ("shoulder_bench.eval.x", "from shoulder_bench import arm\narm._ARM\n"),  # a private attribute
    ("shoulder_bench.tasks.x", "from .. import cli\n"),  # relative: shoulder_bench.cli
])
def test_the_checker_catches(name, source):
    assert check_source(name, source, False, KNOWN)


def test_the_checker_lets_through():
    ok = ("from shoulder_bench import arm\nfrom shoulder_bench.tasks import load\nimport numpy\n"
          "from shoulder_bench.train.ppo import PPOConfig\narm.MODEL_FILE\n")
    assert check_source("shoulder_bench.eval.x", ok, False, KNOWN) == []
    assert check_source("shoulder_bench.cli.x", "from shoulder_bench.authoring import mobl\n", False, KNOWN) == []
