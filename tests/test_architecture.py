"""The house: `pipeline/` is wings in folders (engine, optics, isa, mitsuba, symbolic, shaders, approximate,
stages, publish, from the lowest layer up) under `cli.py` and `runner.py`; `approximate` (`pipeline derive`'s fits,
costs and fronts) sits below the stages, which use its fronts; imports go down the layers only, never across wings of one layer, never in a
cycle; no stage imports another stage; every module name is unique."""

import ast
import functools
from collections import defaultdict
from pathlib import Path

import pipeline

PACKAGE = Path(pipeline.__file__).parent
# Layer of each wing: a module may import its own wing and the layers below it.
LAYER = {"engine": 0, "optics": 1, "isa": 2, "mitsuba": 2, "symbolic": 3, "shaders": 3, "approximate": 4, "stages": 5,
         "publish": 5, "": 6}


def modules() -> dict[str, Path]:
    return {".".join(("pipeline",) + p.relative_to(PACKAGE).with_suffix("").parts).removesuffix(".__init__"): p
            for p in PACKAGE.rglob("*.py")}


def imports(name: str, path: Path, known) -> set[str]:
    """Every `pipeline` module that the file imports, at any depth of its code (lazy imports too)."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")[: len(package.split(".")) - (node.level - 1)] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            targets = [module] + [f"{module}.{a.name}" for a in node.names]
        found |= {t for t in targets if t in known}
    return found - {name}


MODULES = modules()


@functools.cache
def import_graph() -> dict[str, set[str]]:
    """Each module's imports of `pipeline` modules, parsed when a test first asks (not at collection,
    which every worker process of the suite does)."""
    return {name: imports(name, path, MODULES) for name, path in MODULES.items()}


def wing(name: str) -> str:
    """The folder of `pipeline/` a module lies in ("" for the top)."""
    parts = MODULES[name].relative_to(PACKAGE).parts
    return parts[0] if len(parts) > 1 else ""


def test_imports_go_down_the_layers_and_never_across_wings():
    upward, across = [], []
    for name, targets in import_graph().items():
        for target in targets:
            if target == "pipeline":
                continue
            a, b = wing(name), wing(target)
            if LAYER[b] > LAYER[a]:
                upward.append((name, target))
            elif LAYER[b] == LAYER[a] and a != b:
                across.append((name, target))
    assert upward == [] and across == []
    # Every wing is a folder of its own, and the top holds only the command line and the runner.
    assert {wing(m) for m in import_graph()} == set(LAYER)
    assert {m for m in import_graph() if wing(m) == ""} == {"pipeline", "pipeline.__main__", "pipeline.cli", "pipeline.runner",
                                                                  "pipeline.sweep"}


def test_no_import_cycle():
    state: dict[str, int] = defaultdict(int)      # 0 new, 1 on the path, 2 done
    cycles = []

    def visit(name, path):
        state[name] = 1
        for target in sorted(import_graph()[name]):
            if state[target] == 1:
                cycles.append(path[path.index(target):] + [target])
            elif state[target] == 0:
                visit(target, path + [target])
        state[name] = 2

    for name in sorted(import_graph()):
        if state[name] == 0:
            visit(name, [name])
    assert cycles == []


def test_no_stage_imports_another_stage():
    from pipeline.engine import graph
    helpers = {"pipeline.stages.common", "pipeline.stages.family"}     # shared by the stages, not stages
    stages = {m for m in import_graph() if wing(m) == "stages" and m.count(".") == 2} - helpers
    assert stages == {s.module for s in graph.STAGES}
    assert [(m, t) for m in stages for t in import_graph()[m] if t in stages] == []


def test_every_module_name_is_unique():
    names = defaultdict(list)
    for m, path in MODULES.items():
        if path.name != "__init__.py":
            names[path.stem].append(m)
    assert {stem: ms for stem, ms in names.items() if len(ms) > 1 and stem != "__main__"} == {}
