"""The documentation stands alone and keeps up with the code.

docs/errata.md and docs/design.md ship with the repository; code, tests, configs and the README
cite them (and "ERRATA N" items). These tests fail when a citation, a link or a documented name
has nothing behind it, naming what is missing.
"""

import re
from pathlib import Path

import pytest

from vrsweep.config import INITIAL_DEFAULTS, INTEGRATION_DEFAULTS
from vrsweep.numerics.model import DEFAULT_PARAMETERS
from vrsweep.results import Status
from vrsweep.store.variables import point_variables

ROOT = Path(__file__).resolve().parent.parent
ERRATA = ROOT / "docs" / "errata.md"
DESIGN = ROOT / "docs" / "design.md"
TEXT_SUFFIXES = {".py", ".md", ".yaml", ".sh", ".sbatch", ".toml", ".cfg", ".txt"}


def repository_text_files():
    files = [ROOT / "README.md", ROOT / "pyproject.toml"]
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


@pytest.mark.parametrize("document", ["README.md", "docs/errata.md", "docs/design.md"])
def test_relative_links_resolve(document):
    path = ROOT / document
    text = path.read_text(encoding="utf-8")
    headings = {_anchor(h) for h in re.findall(r"^#+ (.+)$", text, re.MULTILINE)}
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+://", target):
            continue
        file_part, _, anchor = target.partition("#")
        linked = (path.parent / file_part).resolve() if file_part else path
        if not linked.exists():
            broken.append(target)
        elif anchor and linked.is_file():
            linked_text = linked.read_text(encoding="utf-8")
            ids = set(re.findall(r'<a id="([^"]+)"></a>', linked_text))
            ids |= headings if linked == path else {_anchor(h) for h in re.findall(r"^#+ (.+)$", linked_text, re.M)}
            if anchor not in ids:
                broken.append(target)
    assert not broken, f"{document}: links to nothing: {broken}"


def _anchor(heading):
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _table_row(text, key):
    """The cells of the Markdown table row whose first cell is `key` (in backticks)."""
    for line in text.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0] == f"`{key}`":
            return cells
    return None


def test_design_documents_every_config_key_with_its_default():
    text = DESIGN.read_text(encoding="utf-8")
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


def test_design_documents_every_status_and_stored_variable():
    text = DESIGN.read_text(encoding="utf-8")
    rows = [[cell.strip() for cell in line.strip().strip("|").split("|")]
            for line in text.splitlines() if line.startswith("|")]
    problems = [f"status {status.name.lower()} = {int(status)}" for status in Status
                if [str(int(status)), f"`{status.name.lower()}`"] not in
                [[row[0].replace("\u2212", "-"), row[1]] for row in rows if len(row) > 1]]

    class Integration:  # every optional variable on: lyapunov, lyapunov_err
        strobe_periods = 16
        lyapunov = True

    stored = [name for name, *_ in point_variables(Integration)]
    stored += ["done", "owned", "A_theory", "A_theory_stable", "A_theory_max_stable", "g_res"]
    documented = " ".join(row[0] for row in rows)
    problems += [f"variable {name}" for name in stored if f"`{name}`" not in documented]
    assert not problems, f"docs/design.md lacks: {problems}"
