"""The documentation stands alone and keeps up with the code.

The user guide (docs/, built as a site by mkdocs.yml), docs/errata.md and docs/design.md ship
with the repository; code, tests, configs and the README cite them (and "ERRATA N" items). These
tests fail when a citation, a link, a page or a documented name has nothing behind it, naming what
is missing. (tests/test_docs_code.py runs the docs' code blocks.)
"""

import re
import unicodedata
from pathlib import Path

import pytest

from vrsweep.config import INITIAL_DEFAULTS, INTEGRATION_DEFAULTS
from vrsweep.numerics.model import DEFAULT_PARAMETERS
from vrsweep.results import Status
from vrsweep.store.variables import point_variables

ROOT = Path(__file__).resolve().parent.parent
ERRATA = ROOT / "docs" / "errata.md"
DESIGN = ROOT / "docs" / "design.md"
CONFIG_PAGE = ROOT / "docs" / "config.md"  # the user guide's table of config keys
TEXT_SUFFIXES = {".py", ".md", ".yaml", ".sh", ".sbatch", ".toml", ".cfg", ".txt"}


def repository_text_files():
    files = [ROOT / "README.md", ROOT / "pyproject.toml"]
    files.append(ROOT / "mkdocs.yml")
    for folder in ("vrsweep", "tests", "configs", "scripts", "examples", "benchmarks", "docs", ".ci"):
        files += [p for p in (ROOT / folder).rglob("*")
                  if p.is_file() and (p.suffix in TEXT_SUFFIXES or p.parent.name == ".ci")
                  and "__pycache__" not in p.parts]
    return [p for p in files if p.exists()]


def test_nothing_refers_to_design_or_errata_files_outside_the_repository():
    outside = ["DESIGN" + ".md", "ERRATA" + ".md", "../" + "shared"]  # spelt apart so this file passes
    offenders = [f"{path.relative_to(ROOT)}: {name}" for path in repository_text_files()
                 for name in outside if name in path.read_text(encoding="utf-8", errors="replace")]
    assert not offenders, offenders


def test_every_cited_errata_item_exists():
    anchors = set(re.findall(r'<a id="errata-(\d+)"></a>', ERRATA.read_text(encoding="utf-8")))
    cited = {}
    for path in repository_text_files():
        for match in re.finditer(r"ERRATA (\d+)(?:\s*[-–]\s*(\d+))?", path.read_text(encoding="utf-8")):
            first, last = int(match.group(1)), int(match.group(2) or match.group(1))
            for item in range(first, last + 1):
                cited.setdefault(str(item), str(path.relative_to(ROOT)))
    assert cited, "no ERRATA citations found: is the pattern still right?"
    missing = {item: where for item, where in cited.items() if item not in anchors}
    assert not missing, f"cited but not in docs/errata.md: {missing}"


DOCUMENTS = ["README.md", "benchmarks/README.md"] + sorted(
    str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md"))


@pytest.mark.parametrize("document", DOCUMENTS)
def test_relative_links_resolve(document):
    """Every relative link leads to a file, and every #anchor to a heading or an <a id>. Pages of
    docs/ are read both on GitHub and on the site (mkdocs), which make anchors from headings
    differently (GitHub keeps non-ASCII letters): an anchor into docs/ must work for both."""
    path = ROOT / document
    text = _without_code(path.read_text(encoding="utf-8"))
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+://", target):
            continue
        file_part, _, anchor = target.partition("#")
        linked = (path.parent / file_part).resolve() if file_part else path
        if not linked.exists():
            broken.append(target)
        elif anchor and linked.is_file():
            if anchor not in _anchors(linked, _github_anchor) or (
                    linked.parent == ROOT / "docs" and anchor not in _anchors(linked, _mkdocs_anchor)):
                broken.append(target)
    assert not broken, f"{document}: links to nothing: {broken}"


def _without_code(text):
    return re.sub(r"^```.*?^```", "", text, flags=re.M | re.S)


def _anchors(path, slug):
    text = _with_snippets(path.read_text(encoding="utf-8"))
    ids = set(re.findall(r'<a id="([^"]+)"></a>', text))
    return ids | {slug(h) for h in re.findall(r"^#+ (.+)$", _without_code(text), re.M)}


def _with_snippets(text):
    """The page as the site shows it: a `--8<-- "FILE"` line (pymdownx.snippets, paths from the
    repository root, as mkdocs.yml sets) replaced by FILE's text."""
    return re.sub(r'^--8<-- "([^"]+)"$', lambda m: (ROOT / m.group(1)).read_text(encoding="utf-8"), text, flags=re.M)


def _github_anchor(heading):
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _mkdocs_anchor(heading):
    """Python-Markdown's (mkdocs' toc) default: code marks dropped, ASCII only, runs of spaces and
    hyphens to one hyphen."""
    ascii_text = unicodedata.normalize("NFKD", heading.replace("`", "")).encode("ascii", "ignore").decode()
    return re.sub(r"[-\s]+", "-", re.sub(r"[^\w\s-]", "", ascii_text).strip().lower())


def test_every_docs_page_is_in_the_site_nav():
    """mkdocs.yml lists every page of docs/ once (adding a page is one line there), and nothing else."""
    from ruamel.yaml import YAML

    def pages(node):
        if isinstance(node, str):
            return [node]
        if isinstance(node, dict):
            return [p for value in node.values() for p in pages(value)]
        return [p for item in node for p in pages(item)]

    nav = pages(YAML(typ="safe").load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))["nav"])
    present = sorted(p.name for p in (ROOT / "docs").glob("*.md"))
    assert sorted(nav) == present, f"in docs/ but not in the nav: {sorted(set(present) - set(nav))}; " \
                                   f"in the nav but not in docs/: {sorted(set(nav) - set(present))}; nav: {nav}"


CITATION = re.compile(r"(README(?:\.md)?|docs/[\w-]+\.md|benchmarks/README\.md)(?:'s)?,? (?:section )?\(?\"([^\"]+)\"")


def test_cited_sections_exist():
    """Code and docs cite sections as `docs/trust.md, "Can R be trusted?"`: each must be a heading
    of that file (a moved or renamed section leaves the citation stale)."""
    stale = []
    for path in repository_text_files():
        for match in CITATION.finditer(path.read_text(encoding="utf-8", errors="replace")):
            document, section = match.groups()
            section = " ".join(section.split())  # a citation wrapped across lines
            if Path(document).stem.isupper() and document.startswith("docs/"):  # a placeholder: docs/PAGE.md
                continue
            target = ROOT / (document if document.endswith(".md") else "README.md")
            headings = re.findall(r"^#+ (.+)$", _without_code(target.read_text(encoding="utf-8")), re.M) \
                if target.exists() else []
            if not any(h.replace("`", "").lower().startswith(section.replace("`", "").lower()) for h in headings):
                stale.append(f"{path.relative_to(ROOT)}: {document}, \"{section}\"")
    assert not stale, f"cited sections that do not exist: {stale}"


def test_every_test_the_docs_cite_exists():
    """The docs cite their evidence as tests (`test_errors`, tests/test_kernel.py,
    `test_global_error_falls_with_rtol`): each is a test file or a test function, so that a
    renamed or removed test does not leave a claim pointing at nothing."""
    files = {p.stem for p in (ROOT / "tests").glob("test_*.py")}
    functions = {name for p in (ROOT / "tests").glob("test_*.py")
                 for name in re.findall(r"^\s*def (test_\w+)", p.read_text(encoding="utf-8"), re.M)}
    cited = {}
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for name in re.findall(r"\b(test_\w+?)(?:\.py)?\b", path.read_text(encoding="utf-8")):
            cited.setdefault(name, path.name)
    missing = {name: page for name, page in cited.items() if name not in files | functions}
    assert cited and not missing, f"tests cited by the docs that do not exist: {missing}"


def _table_row(text, key):
    """The cells of the Markdown table row whose first cell is `key` (in backticks)."""
    for line in text.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0] == f"`{key}`":
            return cells
    return None


@pytest.mark.parametrize("document", [DESIGN, CONFIG_PAGE], ids=["design", "config"])
def test_every_config_key_is_documented_with_its_default(document):
    text = document.read_text(encoding="utf-8")
    keys = {f"parameters.{name}": value for name, value in DEFAULT_PARAMETERS.items()}
    keys.update({f"integration.{name}": value for name, value in INTEGRATION_DEFAULTS.items()})
    problems = []
    for key, default in keys.items():
        row = _table_row(text, key)
        if row is None:
            problems.append(f"{key}: no row in the config table")
        elif isinstance(default, bool):
            if row[1] != str(default).lower():
                problems.append(f"{key}: documented default {row[1]}, code has {default}")
        elif (row[1] != default) if isinstance(default, str) else (float(row[1]) != default):
            problems.append(f"{key}: documented default {row[1]}, code has {default}")
    row = _table_row(text, "initial.x`, `initial.v")
    if row is None or [float(v) for v in row[1].split(",")] != [INITIAL_DEFAULTS["x"], INITIAL_DEFAULTS["v"]]:
        problems.append("initial.x, initial.v: row missing or defaults differ")
    assert not problems, problems


def test_every_section_key_is_documented():
    """The keys the config's other sections accept (the continuation section, a sweep axis, a
    written model, its barriers and response) each have a row or a mention on the page that
    documents the section, the continuation section's with the code's default, and a written
    model's required keys are said to be required."""
    from vrsweep.config.models import BARRIER_KEYS, MODEL_KEYS, REQUIRED_KEYS, RESPONSE_KEYS
    from vrsweep.config.schema import CONTINUATION_KEYS, LINEAR_KEYS, VALUES_KEYS
    from vrsweep.numerics.settings import CONTINUATION_DEFAULTS

    def page(name):
        return (ROOT / "docs" / name).read_text(encoding="utf-8")

    problems = []
    continuation = page("continuation.md")
    for key in CONTINUATION_KEYS:
        row = _table_row(continuation, key)
        if row is None:
            problems.append(f"continuation.md: no row for continuation.{key}")
        elif key in CONTINUATION_DEFAULTS and float(row[1]) != CONTINUATION_DEFAULTS[key]:
            problems.append(f"continuation.md: continuation.{key} documented default {row[1]}, "
                            f"code has {CONTINUATION_DEFAULTS[key]}")
    from vrsweep.config.schema import SECTIONS

    problems += [f"config.md: no row for the section {key}" for key in SECTIONS
                 if not any(line.startswith(f"| `{key}") for line in page("config.md").splitlines())]
    config = page("config.md").split("## Sweep axes", 1)[1]
    problems += [f"config.md, Sweep axes: no `{key}`" for key in set(LINEAR_KEYS + VALUES_KEYS)
                 if not re.search(rf"\b{key}\b", config)]
    models = page("models.md")
    for key in MODEL_KEYS:
        row = _table_row(models, key)
        if row is None:
            problems.append(f"models.md: no row for model.{key}")
        elif key in REQUIRED_KEYS and not row[1].startswith("required"):
            problems.append(f"models.md: model.{key} is required; its row does not say so")
    problems += [f"models.md: model.barriers' key {key} not named" for key in BARRIER_KEYS
                 if key not in " ".join(_table_row(models, "barriers") or [])]
    problems += [f"models.md: model.response's key {key} not named" for key in RESPONSE_KEYS
                 if f"`{key}`" not in " ".join(_table_row(models, "response") or [])]
    assert not problems, problems


def _status_problems(text):
    rows = [[cell.strip() for cell in line.strip().strip("|").split("|")]
            for line in text.splitlines() if line.startswith("|")]
    return [f"status {status.name.lower()} = {int(status)}" for status in Status
            if [str(int(status)), f"`{status.name.lower()}`"] not in
            [[row[0].replace("\u2212", "-"), row[1]] for row in rows if len(row) > 1]], rows


def test_the_guide_documents_every_status():
    problems, _ = _status_problems((ROOT / "docs" / "file-format.md").read_text(encoding="utf-8"))
    assert not problems, f"docs/file-format.md lacks: {problems}"


def _stored_variables():
    class Integration:  # every optional variable on: lyapunov, lyapunov_err
        strobe_periods = 16
        lyapunov = True

    stored = [name for name, *_ in point_variables(Integration)]
    return stored + ["done", "A_theory", "A_theory_stable", "A_theory_max_stable", "g_res"]


def test_the_guide_documents_every_stored_variable():
    """docs/file-format.md's table of a sweep file is where a user learns what it holds:
    `x_final`, `v_final`, `n_steps` and `n_rhs` were in every file but only in design.md."""
    text = (ROOT / "docs" / "file-format.md").read_text(encoding="utf-8")
    section = text.split("## What a sweep file holds", 1)[1].split("\n## ", 1)[0]
    documented = " ".join(line.split("|")[1] for line in section.splitlines() if line.startswith("|"))
    missing = [name for name in _stored_variables() if f"`{name}`" not in documented]
    assert not missing, f"docs/file-format.md's sweep file table lacks: {missing}"


def test_design_documents_every_status_and_stored_variable():
    problems, rows = _status_problems(DESIGN.read_text(encoding="utf-8"))

    class Integration:  # every optional variable on: lyapunov, lyapunov_err
        strobe_periods = 16
        lyapunov = True

    stored = [name for name, *_ in point_variables(Integration)]
    stored += ["done", "owned", "A_theory", "A_theory_stable", "A_theory_max_stable", "g_res"]
    documented = " ".join(row[0] for row in rows)
    problems += [f"variable {name}" for name in stored if f"`{name}`" not in documented]
    assert not problems, f"docs/design.md lacks: {problems}"


def test_the_pages_call_the_barrier_line_by_its_style():
    """The barrier line A/c = Δ/c became dash-dot-dot (plot/sweeps.py BARRIER_DASHES); the README,
    index.md and paper.md still called it dotted, which a sweep's joining lines are."""
    from vrsweep.plot.sweeps import BARRIER_DASHES

    assert len(BARRIER_DASHES[1]) == 6  # a dash and two dots
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = " ".join(page.read_text(encoding="utf-8").split())
        for phrase in ("capped by the barrier (dotted", "(dotted: A/c = Δ/c", "Δ = 1 (dotted level)"):
            assert phrase not in text, f"{page.name}: {phrase}"
