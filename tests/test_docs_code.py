"""Every code block of the user guide (docs/*.md) and the README runs, or is checked, here.

- ```python blocks run as written, in order, page by page, each page in its own folder and
  namespace (as a notebook runs its cells; docs/python-api.md is run by tests/test_api.py). A block
  names the files it reads in its first comment lines, as the commands that make them
  (``# vrsweep run configs/quickstart.yaml   (writes quickstart.h5)``); the test runs those
  commands first, on shorter windows (``SHORT``), once per page.
- ```yaml blocks are configs: each must load, and one that says it shows a shipped config
  (``# configs/NAME.yaml: ...``) must be that config, but for its output file.
- Every ``vrsweep ...`` command in a ```bash or ```text block, in inline code or in a shipped
  config's comments names a real
  command and only its real options (and ``--kind`` only its real kinds); every ```bash command that
  names a shipped config runs as ``vrsweep validate`` with the same ``--set``s (nothing is
  computed), and ``scripts/make_figures.py NAME`` names a real figure; and (slow) every page's
  ```bash commands run in order, as a reader would type them, on 2 + 2 slow periods.

A stale option, a renamed config, a config key that no longer exists or a snippet that no longer
runs fails here, naming the page and the block.
"""

import glob
import importlib.util
from dataclasses import replace
import os
import re
import shlex
from pathlib import Path

import click
import numpy as np
import pytest

from vrsweep.cli import main
from vrsweep.config import load_config, parse_config

pytest.importorskip("xarray")

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SHORT = ("--set", "transient_periods=2", "--set", "measure_periods=2", "--set", "strobe_periods=2")
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```\s*$", re.M | re.S)


def page_id(path):
    return str(path.relative_to(ROOT))


def code_blocks(path, language=None):
    """[(language, code, line number)] of the fenced blocks of a Markdown file."""
    text = path.read_text(encoding="utf-8")
    blocks = [(m.group(1), m.group(2), text.count("\n", 0, m.start()) + 1) for m in FENCE.finditer(text)]
    return [b for b in blocks if language is None or b[0] == language]


def pages_with(language):
    return [pytest.param(p, id=page_id(p)) for p in PAGES if code_blocks(p, language)]


# --- python ---------------------------------------------------------------------------------

def commands_in_header(code):
    """The `vrsweep ...` commands of a block's first comment lines (a command ends at two spaces)."""
    commands = []
    for line in code.splitlines():
        if not line.startswith("#"):
            break
        match = re.match(r"#\s+(vrsweep \S.*?)(?:\s{2,}.*)?$", line)
        if match:
            commands.append(shlex.split(match.group(1))[1:])
    return commands


# Pages whose python blocks a test of their own runs (and checks the results of): that test must
# name the page, so it cannot drift away unseen.
RUN_ELSEWHERE = {"docs/python-api.md": "tests/test_api.py"}


def test_pages_run_elsewhere_are_run_there():
    for page, test_file in RUN_ELSEWHERE.items():
        if (ROOT / page).exists():
            assert page in (ROOT / test_file).read_text(encoding="utf-8"), f"{test_file} no longer runs {page}"


@pytest.mark.parametrize("page", [p for p in pages_with("python") if p.id not in RUN_ELSEWHERE])
def test_python_blocks_run(page, tmp_path, monkeypatch, invoke):
    """A page's blocks run in order in one namespace, as a notebook runs its cells."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    (tmp_path / "configs").symlink_to(ROOT / "configs")  # the blocks' commands name configs/...
    done, namespace = set(), {}
    try:
        for number, (_, code, line) in enumerate(code_blocks(page, "python"), 1):
            for words in commands_in_header(code):
                if tuple(words) in done:
                    continue
                done.add(tuple(words))
                extra = ["--quiet", "--overwrite", *SHORT] if words[0] == "run" else ["--overwrite"]
                result = invoke(*words, *extra)
                assert result.exit_code == 0, f"{page_id(page)}:{line}: vrsweep {shlex.join(words)}\n{result.output}"
            exec(compile(code, f"{page_id(page)}:{line} (python block {number})", "exec"), namespace)
    finally:
        _end_of_notebook(namespace)


def _end_of_notebook(namespace):
    """Close what a page's blocks left open, as a notebook's kernel does when it stops: a lazily
    read Dataset keeps its HDF5 file open, and a later test counts the files this process has open."""
    import gc

    import h5py
    import xarray as xr

    for value in namespace.values():
        if isinstance(value, (xr.Dataset, xr.DataArray, h5py.File)):
            value.close()
    namespace.clear()
    gc.collect()


def test_the_python_pages_show_each_way_in():
    joined = "\n".join(code for page in PAGES for _, code, _ in code_blocks(page, "python"))
    for needle in ("vrsweep.open_results(", ".sel(Omega=", ".plot(", ".to_dataframe()", "h5py.File(",
                   'group="effective"', "xr.open_dataset("):
        assert needle in joined, needle


# --- yaml -----------------------------------------------------------------------------------

@pytest.mark.parametrize("page", pages_with("yaml"))
def test_yaml_blocks_are_valid_configs(page):
    for _, code, line in code_blocks(page, "yaml"):
        config = parse_config(code, source_name=f"{page_id(page)}:{line}")  # ConfigError names the line
        shown = re.match(r"#\s*(configs/[\w.]+\.yaml)\s*:", code)
        if shown:
            shipped = load_config(ROOT / shown.group(1))
            assert replace(config, output=None) == replace(shipped, output=None), (
                f"{page_id(page)}:{line}: the block says it shows {shown.group(1)}, but differs from it")


# --- command lines ----------------------------------------------------------------------------

def command_lines(path):
    """(text, where, in_bash_block) of every `vrsweep ...` command the page shows: lines of bash
    and text blocks (with their indented continuation lines) and inline code spans; in a shipped
    config, its comment lines that are commands (`vrsweep init` copies them to users)."""
    found = []
    text = path.read_text(encoding="utf-8")
    if path.suffix == ".yaml":
        for number, line in enumerate(text.splitlines(), 1):
            body = line.lstrip("#").strip()
            if line.startswith("#") and body.startswith("vrsweep "):
                found.append((body.split("  #")[0].strip(), f"{page_id(path)}:{number}", False))
        return found
    for language, code, line in code_blocks(path):
        if language not in ("bash", "text", ""):
            continue
        lines = code.splitlines()
        for index, body in enumerate(lines):
            if not body.startswith("vrsweep "):
                continue
            command = body.split("  #")[0]
            for more in lines[index + 1:]:
                if not more.startswith(" "):
                    break
                command = command.rstrip() + ("" if command.rstrip().endswith("|") else " ") + more.strip()
            found.append((command, f"{page_id(path)}:{line + 1 + index}", language == "bash"))
    outside = FENCE.sub("", text)
    for match in re.finditer(r"`(vrsweep [^`]+)`", outside):
        found.append((match.group(1), f"{page_id(path)}: `{match.group(1)}`", False))
    return found


def _option_names(command):
    names = {"--help", "-h"}
    for param in command.params:
        names.update(param.opts)
        names.update(param.secondary_opts)
    return names


def _kinds():
    (kind,) = [p for p in main.commands["plot"].params if p.name == "kind"]
    return set(kind.type.choices)


def _placeholder(word):
    return word.isupper() or word in ("...", "…")


CONFIGS = sorted((ROOT / "configs").glob("*.yaml"))


@pytest.mark.parametrize("page", [pytest.param(p, id=page_id(p)) for p in PAGES + CONFIGS if command_lines(p)])
def test_commands_name_real_options(page):
    problems = []
    for command, where, _ in command_lines(page):
        words = [w.strip("[]()") for w in command.split()]
        name = words[1]
        if name.startswith("-"):
            if name not in ("--version", "--help", "-h"):
                problems.append(f"{where}: vrsweep has no option {name}")
            continue
        if _placeholder(name):  # vrsweep COMMAND --help
            continue
        if name not in main.commands:
            looks_like_a_command = len(words) == 2 or re.match(r"-|.*\.(yaml|h5)$", words[2])
            if looks_like_a_command:  # not prose such as `vrsweep 0.1.0 (numba ...)`
                problems.append(f"{where}: no command {name!r}")
            continue
        options = _option_names(main.commands[name])
        for index, word in enumerate(words[2:], 2):
            option = word.split("=")[0].rstrip(",.;:")
            if re.match(r"--?[a-zA-Z]", option) and option not in options:
                problems.append(f"{where}: vrsweep {name} has no option {option}")
            if option == "--kind" and index + 1 < len(words):
                values = [v for v in words[index + 1].split("|") if v and not _placeholder(v)]
                problems += [f"{where}: no --kind {v}" for v in values if v not in _kinds()]
    assert not problems, problems


def _synopsis():
    """The Synopsis block of docs/commands.md, as {command: its lines} (a command's continuation
    lines are indented; comments after two spaces and a # dropped)."""
    text = (ROOT / "docs" / "commands.md").read_text(encoding="utf-8")
    block = re.search(r"^## Synopsis\s+```text\n(.*?)^```", text, re.M | re.S).group(1)
    lines, name = {}, None
    for line in block.splitlines():
        match = re.match(r"vrsweep (\w+)", line)
        name = match.group(1) if match else name
        lines[name] = lines.get(name, "") + line.split("  #")[0] + "\n"
    return lines


def test_the_synopsis_names_every_option_and_kind():
    """docs/commands.md's Synopsis is where a user looks for an option: every option of every
    command (and every --kind, every choice) is there, under its command. `theory --set`,
    `continue --switch`, `merge --overwrite`, `--quiet` of three commands and `plot --kind motion`
    were missing."""
    synopsis, missing = _synopsis(), []
    for name, command in main.commands.items():
        lines = synopsis.get(name, "")
        for param in command.params:
            if not param.opts[0].startswith("-") or param.name == "help":
                continue
            names = param.opts + param.secondary_opts
            if not any(re.search(re.escape(o) + r"(?![\w-])", lines) for o in names):
                missing.append(f"vrsweep {name} {names[0]}")
            choices = getattr(param.type, "choices", None) or ()
            missing += [f"vrsweep {name} {names[0]} {c}" for c in choices
                        if not re.search(r"(?<![\w+])" + re.escape(c) + r"(?![\w+])", lines)]
    assert not missing, f"not in docs/commands.md's Synopsis: {missing}"
    for name, lines in synopsis.items():  # and nothing there that the command lacks
        known = {o for p in main.commands[name].params for o in p.opts + p.secondary_opts}
        listed = set(re.findall(r"(?<![\w-])(--?[a-zA-Z][\w-]*)", lines))
        assert listed <= known, f"vrsweep {name}: the Synopsis lists {sorted(listed - known)}, which it lacks"


@pytest.mark.parametrize("name", sorted(main.commands))
def test_help_text_is_rendered(name, invoke):
    """Click prints an option's help as written (no %-formatting): `plot --help` said
    "span under 1 %% of the axis"."""
    result = invoke(name, "--help")
    assert result.exit_code == 0, result.output
    assert "%%" not in result.output, result.output


@pytest.mark.parametrize("page", [pytest.param(p, id=page_id(p)) for p in PAGES
                                  if any(bash for *_, bash in command_lines(p))])
def test_bash_commands_on_shipped_configs_validate(page, invoke, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for command, where, bash in command_lines(page):
        words = shlex.split(command)
        if not bash or len(words) < 3 or words[1] not in ("run", "validate", "theory", "simulate"):
            continue
        config = ROOT / words[2]
        if not config.is_file():
            assert _placeholder(words[2]) or not words[2].startswith("configs/"), f"{where}: no {words[2]}"
            continue
        sets = [arg for i, arg in enumerate(words) if i > 0 and words[i - 1] == "--set"]
        result = invoke("validate", config, *[x for s in sets for x in ("--set", s)])
        assert result.exit_code == 0, f"{where}: {command}\n{result.output}"


def bash_commands(path):
    """The `vrsweep ...` commands of a page's ```bash blocks, in order, as word lists (a line's
    `pip install . && vrsweep ...` gives its vrsweep part); none with a placeholder (CONFIG.yaml)."""
    commands = []
    for _, code, line in code_blocks(path, "bash"):
        for body in code.splitlines():
            for part in body.split("  #")[0].split("&&"):
                words = shlex.split(part)
                if words[:1] == ["vrsweep"] and not any(_placeholder(Path(w).stem) for w in words[1:]):
                    commands.append((words[1:], f"{page_id(path)}:{line}"))
    return commands


@pytest.mark.slow
@pytest.mark.parametrize("page", [pytest.param(p, id=page_id(p)) for p in PAGES if bash_commands(p)])
def test_bash_blocks_run(page, invoke, tmp_path, monkeypatch):
    """A page's shell commands, run in order in one folder as a reader would type them, each sweep
    on 2 + 2 slow periods: each must succeed (a file the next one reads, a plot, a merge...)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    (tmp_path / "configs").symlink_to(ROOT / "configs")
    for words, where in bash_commands(page):
        words = [match for w in words for match in (sorted(glob.glob(w)) if "*" in w else [w])]
        extra = ["--quiet", *SHORT] if words[0] == "run" else []
        result = invoke(*words, *extra)
        assert result.exit_code == 0, f"{where}: vrsweep {shlex.join(words)}\n{result.output}"


def test_make_figures_names_real_figures():
    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "scripts" / "make_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    problems = []
    for page in PAGES:
        for match in re.finditer(r"python scripts/make_figures\.py((?: [\w+]+)*)", page.read_text(encoding="utf-8")):
            problems += [f"{page_id(page)}: {name}" for name in match.group(1).split() if name not in module.COMMANDS]
    assert not problems, f"make_figures.py has no figure: {problems}"
    assert Path(ROOT / "docs" / "figures").is_dir()
    missing = [f"{name}: {words[-1]}" for name, commands in module.COMMANDS.items() for words in commands
               if words[0] == "plot" and not (ROOT / words[words.index("-o") + 1]).is_file()]
    assert not missing, f"figures make_figures.py makes but the repository lacks: {missing}"


def test_every_example_the_docs_name_is_shipped():
    shipped = {p.stem for p in (ROOT / "configs").glob("*.yaml")}
    named = set()
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        named |= {name for name in re.findall(r"configs/(\w+)\.yaml", text) if not name.isupper()}
        named |= {name for name in re.findall(r"--example (\w+)", text) if not name.isupper()}
    assert named - shipped == set(), f"named in the docs, not in configs/: {sorted(named - shipped)}"
    assert os.path.isdir(ROOT / "configs")



def test_make_figures_follows_the_free_orbits_graze(invoke, tmp_path, monkeypatch):
    # The free period-1 orbit's branch crosses its graze (g = 37.98) onto impacting orbits with a
    # graze of their own at a lower g, listed first: the recipe followed that one (--point 0), which
    # continue refuses, so `make_figures.py curves_original` stopped at exit 2.
    import h5py

    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "scripts" / "make_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    steps = [words for words in module.COMMANDS["curves_original"]
             if words[0] == "continue" and "curves_branch_original_free" in " ".join(map(repr, words))]
    assert len(steps) == 2, steps
    monkeypatch.chdir(tmp_path)
    (tmp_path / "configs").symlink_to(ROOT / "configs")
    (tmp_path / "results").mkdir()
    for words in steps:
        words = module.resolve(words)  # the --point of the graze at 37.98, found in the branch just made
        result = invoke(*words)
        assert result.exit_code == 0, f"vrsweep {shlex.join(words)}\n{result.output}"
    with h5py.File(tmp_path / steps[1][steps[1].index("-o") + 1], "r") as f:
        kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in f["curve_kind"][()]]
        g, delta = f["g"][()], f["Delta"][()]
    # The curve passes through the branch's own graze: Delta = 2.5 (the config's) near g = 37.98.
    assert kinds == ["grazing"] and abs(np.interp(37.98, np.sort(g), delta[np.argsort(g)]) - 2.5) < 0.01


def test_make_figures_hysteresis_draws_the_stable_orbit_each_down_sweep_point_lies_on(invoke, tmp_path,
                                                                                      monkeypatch):
    """docs/figures/continuation_hysteresis.png drew the down-sweep's triangles by the dashed
    unstable impacting orbits (R within 0.05-4 % of theirs) and not the stable impacting orbit
    they are on: a reader concluded the sweep found unstable orbits. Every period-1 point of the
    recipe's down-sweep must lie on a stable orbit of a branch the recipe draws: R within 1e-3 at
    its g, interpolated between the branch's points (spaced 0.3 in g or less; the impacting orbit's
    R is nearly straight in g, the small orbit's curves too much by its fold for a straight line)."""
    import vrsweep

    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "scripts" / "make_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    (tmp_path / "configs").symlink_to(ROOT / "configs")
    (tmp_path / "results").mkdir()
    (tmp_path / "docs" / "figures").mkdir(parents=True)
    commands = module.COMMANDS["continuation_hysteresis"]
    for words in commands:
        words = module.resolve(words)
        result = invoke(*words, *([] if words[0] == "plot" else ["--quiet"]))
        assert result.exit_code == 0, f"vrsweep {shlex.join(words)}\n{result.output}"
    plot = commands[-1]
    drawn = [vrsweep.open_results(name).load() for name in plot[1:plot.index("-o")]]
    for data in drawn:
        data.close()  # left open, xarray's cache kept the files open for the worker's later tests
    branches = [data for data in drawn if data.attrs["vrsweep_file"] == "branch"]
    sweeps = [data for data in drawn if data.attrs["vrsweep_file"] != "branch"]
    assert len(sweeps) == 1 and branches
    stretches = []  # (g, R) of each run of consecutive stable orbits, sorted by g
    for data in branches:
        stable, branch = data["stable"].values.astype(bool), data["branch"].values
        g, R = data["parameter"].values, data["R"].values
        edges = np.flatnonzero(np.diff(stable.astype(int)) | np.diff(branch)) + 1
        for piece in np.split(np.arange(g.size), edges):
            if stable[piece[0]] and piece.size > 1:
                order = np.argsort(g[piece])
                stretches.append((g[piece][order], R[piece][order]))
    sweep = sweeps[0]
    misplaced, checked = [], 0
    down = sweep.sel(direction=-1)
    for g, R, period in zip(down["g"].values, down["R"].values, down["period"].values):
        if period != 1:
            continue
        checked += 1
        near = [abs(np.interp(g, gs, Rs) - R) for gs, Rs in stretches if gs[0] <= g <= gs[-1]]
        if not near or min(near) > 1e-3 * R:
            misplaced.append((float(g), float(R), min(near, default=None)))
    assert checked == 25, checked  # the down-sweep's points, g = 21 to 27: all period 1
    assert not misplaced, f"sweep points on no stable orbit the figure draws: {misplaced}"


def test_make_figures_names_each_followed_bifurcation_by_its_kind_and_place(tmp_path, monkeypatch):
    """The recipes gave --point as the bifurcation's index in its branch file (--point 2): a change
    in the branch (a graze located first, one bifurcation more) followed another point with no word
    said, and changed the figure. Every --point is named by kind and parameter, and found in the
    file when the command runs; none, or two, stop the recipe naming what the file lists."""
    from handmade import write_switched_branch_file

    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "scripts" / "make_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    points = [words[words.index("--point") + 1] for commands in module.COMMANDS.values() for words in commands
              if "--point" in words]
    assert len(points) == 8 and all(isinstance(point, module.Bifurcation) for point in points), points
    # The doublings of the handmade branch file: g = 24 (listed first) and g = 25.
    path = write_switched_branch_file(tmp_path / "switched.h5")
    words = ["continue", str(path), "--point", module.Bifurcation(path, "period_doubling", 25.0)]
    assert module.resolve(words) == ["continue", str(path), "--point", "1"]
    assert module.resolve([module.Bifurcation(path, "period_doubling", 24.0)]) == ["0"]
    with pytest.raises(SystemExit, match="has 0 fold points within 0.01 of 24.*0: period_doubling at 24"):
        module.resolve([module.Bifurcation(path, "fold", 24.0)])
    with pytest.raises(SystemExit, match="has 2 period_doubling points within 2 of 24.5"):
        module.resolve([module.Bifurcation(path, "period_doubling", 24.5, within=2.0)])


def test_make_figures_shrinks_a_figure_without_moving_its_lines_colours(tmp_path):
    """make_figures re-saves the docs' PNGs with a palette; a median cut to 32 colours spent them
    on antialiased greys and drew the branch figure's red period (#CC3311) 97 levels off, dark
    brown. Thin lines in every colour a curve or a period takes keep their colour to 3 levels."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from PIL import Image

    from vrsweep.plot.palettes import LINE_COLOURS, QUALITATIVE
    from matplotlib.colors import to_rgb

    spec = importlib.util.spec_from_file_location("make_figures", ROOT / "scripts" / "make_figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    colours = list(dict.fromkeys(LINE_COLOURS + QUALITATIVE))
    fig = Figure(figsize=(7.5, 6.5))
    ax = fig.subplots()
    x = np.linspace(0.0, 1.0, 200)
    for k, colour in enumerate(colours):
        ax.plot(x, np.sin(3 * x + k) + 0.3 * k, color=colour, lw=1.8)
        ax.text(0.1, 0.3 * k, "text in grey " * 3, color="0.3", fontsize="x-small")  # greys to spend colours on
    ax.set_title("a title " * 8)
    path = tmp_path / "figure.png"
    fig.savefig(path, dpi=110)
    before = np.asarray(Image.open(path).convert("RGB")).astype(float)
    module.shrink_png(path)
    after = np.asarray(Image.open(path).convert("RGB")).astype(float)
    for colour in colours:
        target = np.array(to_rgb(colour)) * 255
        drawn = np.all(np.abs(before - target) < 2.0, axis=2)
        assert drawn.sum() > 100, colour
        moved = np.abs(after[drawn] - target).max(axis=1)
        assert np.median(moved) <= 3.0, (colour, float(np.median(moved)))


# Words that belong to the paper's model alone: its slow period 2 pi/omega, its g_res and Omega,
# its equations and figures, its two systems and its gain |Q|/c.
PAPER_ONLY = ("slow period", "g_res", "Omega", "eq2.", "eq3.", "Fig.", "effective", "original", "A/c", "|Q|/c")


@pytest.mark.parametrize("name", [None, *sorted(main.commands)])
def test_help_names_the_papers_model_where_it_speaks_of_it(name, invoke):
    """`plot --help` said 'impacts per slow period', 'g_res(Omega) drawn on it', 'original above
    effective' and 'R = |Q|/c' as if every model were the paper's; for a written model none of
    it holds. Each such word now sits within a clause that names the paper's model (general
    wording elsewhere): 'paper' within 150 characters of it."""
    result = invoke(*([name] if name else []), "--help")
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    unnamed = []
    for word in PAPER_ONLY:
        for match in re.finditer(re.escape(word), text):
            if "paper" not in text[max(0, match.start() - 150):match.end() + 150]:
                unnamed.append(text[max(0, match.start() - 60):match.end() + 60])
    assert not unnamed, unnamed
