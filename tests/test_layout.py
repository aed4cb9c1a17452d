"""The package is laid out by layer, and the imports keep the layers honest (read with ast, so
imports inside functions count as much as those at the top).

    numerics/   everything numba compiles; imports nothing above errors/results
    analysis/   computed from the numerics, no kernels of its own
    config/     YAML -> Config, Grid
    store/      files: layout, writing, reading; computes nothing
    execution/  runs sweeps: the one layer that both computes and writes
    plot/       figures from files and Datasets
    commands/   the command line; cli.py registers the commands

A layer may import the layers listed for it in ALLOWED and nothing else.
"""

import ast
import re
from pathlib import Path

import pytest

import vrsweep

PACKAGE = Path(vrsweep.__file__).resolve().parent
BASE = {"errors", "results", "_version", "numbertext"}

# layer -> the layers it may import (besides itself and BASE).
ALLOWED = {
    "numerics": set(),
    "analysis": {"numerics"},
    # numba-free: reading a config must not import numba. numerics.expressions, written and
    # coefficients are plain Python and numpy: a written model is checked without compiling it.
    "config": {"numerics.model", "numerics.settings", "numerics.expressions", "numerics.written",
               "numerics.coefficients"},
    "store": {"config", "analysis", "numerics.model"},  # numerics.model: parameter names and units only
    "execution": {"numerics", "analysis", "config", "store"},
    # model: parameter symbols for labels; written: where a written model's barriers are drawn
    "plot": {"analysis", "config", "store", "numerics.model", "numerics.written"},
    # mpl_folder: plot says where matplotlib's folder went when it is not its usual one
    "commands": {"numerics", "analysis", "config", "store", "execution", "plot", "cli", "mpl_folder"},
}
# Top-level modules, each with the reason it is not in a layer.
TOP_LEVEL = {
    "__init__": "the package: the public API, imported lazily",
    "__main__": "python -m vrsweep",
    "_version": "the version, read by the build without importing the package",
    "errors": "the exceptions every layer raises",
    "numbertext": "numbers typed as text (options, YAML, a written model's literals), read by one rule in every layer",
    "results": "the point statuses every layer reads",
    "cli": "the console script's entry point (pyproject.toml), registering the commands",
    "mpl_folder": "matplotlib's folder, chosen when the package is imported: config and plot import matplotlib",
}


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        yield path, parts


def _imported(path):
    """Every vrsweep module ``path`` imports, as dotted names below vrsweep ('numerics.kernel')."""
    tree = ast.parse(path.read_text(), filename=str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "vrsweep":
                names.update(f"vrsweep.{alias.name}" for alias in node.names)
            else:
                names.update(f"{node.module}.{alias.name}" for alias in node.names)
                names.add(node.module)
    return {name[len("vrsweep."):] for name in names if name.startswith("vrsweep.")}


def _layer(dotted):
    return dotted.split(".")[0]


def test_every_module_is_in_a_layer_or_says_why_it_is_not():
    top = {parts[0] for _, parts in _modules() if len(parts) == 1}
    layers = {parts[0] for _, parts in _modules() if len(parts) > 1}
    assert top <= set(TOP_LEVEL), (
        f"modules at the top level with no reason given in tests/test_layout.py: {sorted(top - set(TOP_LEVEL))}; "
        "put them in a layer")
    assert layers == set(ALLOWED), sorted(layers ^ set(ALLOWED))


@pytest.mark.parametrize("layer", sorted(ALLOWED))
def test_a_layer_imports_only_the_layers_below_it(layer):
    wrong = []
    for path, parts in _modules():
        if parts[0] != layer or len(parts) == 1:
            continue
        for name in _imported(path):
            top = _layer(name)
            if top in (layer, *BASE) or top not in ALLOWED and top not in TOP_LEVEL:
                continue  # itself, the base, or a name from the package root (vrsweep.__version__)
            if top in ALLOWED[layer] or any(name == a or name.startswith(a + ".") for a in ALLOWED[layer]):
                continue
            wrong.append(f"{path.relative_to(PACKAGE.parent)} imports vrsweep.{name}")
    assert not wrong, "\n".join(wrong)


def test_every_numba_compiled_function_lives_in_numerics():
    outside = [str(path.relative_to(PACKAGE.parent)) for path, parts in _modules()
               if parts[0] != "numerics" and re.search(r"@(kernel_jit|njit|jit|numba\.)", path.read_text())]
    assert not outside, outside


def _graph():
    graph = {}
    for path, parts in _modules():
        name = ".".join(p for p in parts if p != "__init__")
        graph[name] = {n for n in _imported(path) if n != name}
    known = set(graph)
    # "from vrsweep.numerics import kernel" names the module numerics.kernel; a name that is not a
    # module (numerics.kernel.SUM_R) stands for its module.
    for name, targets in graph.items():
        resolved = set()
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != name:
                resolved.add(target)
        graph[name] = resolved
    return graph


def test_no_import_cycles_between_modules():
    graph = _graph()
    # A package's __init__ re-exporting its modules is not a cycle of the design: leave out the
    # edges from a package to its own modules.
    for name in graph:
        graph[name] = {t for t in graph[name] if not t.startswith(name + ".")}
    state, cycles = {}, []

    def visit(node, stack):
        state[node] = "open"
        for target in sorted(graph.get(node, ())):
            if state.get(target) == "open":
                cycles.append(" -> ".join(stack[stack.index(target):] + [target]))
            elif target not in state:
                visit(target, stack + [target])
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert not cycles, "\n".join(cycles)


FLAG = re.compile(r"(?<![\w-])--[a-z][a-z-]+")
# (layer, flag) -> why that layer may quote it.
QUOTED_FLAGS = {
    ("config", "--set"): "overrides are written NAME=VALUE in the config's own override language, "
                         "and a problem quotes the override as given ('--set g=x: ...'), from Python too",
}


def test_only_the_commands_speak_in_command_line_flags():
    """Library messages name arguments ({overwrite}); commands reword them as --overwrite."""
    speaking = []
    for path, parts in _modules():
        if parts[0] in ("commands", "cli"):
            continue
        tree = ast.parse(path.read_text())
        docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                      if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef))
                      and node.body and isinstance(node.body[0], ast.Expr)
                      and isinstance(node.body[0].value, ast.Constant)}
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
                for flag in FLAG.findall(node.value):
                    if (parts[0], flag) in QUOTED_FLAGS:
                        continue
                    speaking.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}: {flag}")
    assert not speaking, "\n".join(speaking)


def test_only_numerics_and_execution_import_the_cuda_target():
    """numba's CUDA target (numba.cuda, numba_cuda) is imported by the GPU's kernels (numerics/cuda.py)
    and where a run decides whether it can use them (execution/device.py), nowhere else: the CLI
    and the config work where the extra vrsweep[cuda] is not installed."""
    pattern = re.compile(r"^\s*(from numba import cuda|import numba\.cuda|from numba\.cuda|import numba_cuda|"
                         r"from numba_cuda)", re.MULTILINE)
    offenders = [str(path.relative_to(PACKAGE)) for path in PACKAGE.rglob("*.py")
                 if pattern.search(path.read_text()) and path.relative_to(PACKAGE).parts[0] not in
                 ("numerics", "execution")]
    assert offenders == []
