"""The documentation site (mkdocs.yml): the file-format references, the G-code page and the API
reference from the docstrings, built strictly as CI builds it -- a warning fails the build
(an object that no longer exists, a broken link or anchor, a docstring griffe cannot read).

The API pages must cover what the README shows: every public name of ``motionplc.planning``,
``motionplc.planning.paths``, ``motionplc.blocks`` (and the group blocks),
``motionplc.runtime`` and ``motionplc.fieldbus``, and ``build`` / ``Machine.attach`` /
``load_config`` / ``Runtime.run_until``.
"""

from __future__ import annotations

import importlib
import importlib.util
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
API_MODULES = {  # module -> its API page
    "motionplc.planning": "planning",
    "motionplc.planning.paths": "paths",
    "motionplc.blocks": "blocks",
    "motionplc.blocks.group_blocks": "blocks",
    "motionplc.runtime": "runtime",
    "motionplc.fieldbus": "fieldbus",
}
# documented under another path (a module of the package has the function's name)
ANCHOR_OF = {"motionplc.planning.plan": "motionplc.planning.plan.plan"}


def mkdocs(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    run = mkdocs("-q", "-d", str(out))
    assert run.returncode == 0, run.stderr[-3000:]
    assert "WARNING" not in run.stderr and "ERROR" not in run.stderr, run.stderr[-3000:]
    return out


def anchors(page: Path) -> set[str]:
    return set(re.findall(r'\bid="([^"]+)"', page.read_text(encoding="utf-8")))


def test_api_pages_cover_every_public_name(site: Path) -> None:
    missing = []
    for module, page in API_MODULES.items():
        ids = anchors(site / "api" / f"{page}.html")
        for name in importlib.import_module(module).__all__:
            full = f"{module}.{name}"
            if ANCHOR_OF.get(full, full) not in ids:
                missing.append(f"{full} (api/{page}.html)")
    assert missing == []
    runtime = anchors(site / "api" / "runtime.html")
    for full in (
        "motionplc.config.build",
        "motionplc.config.load_config",
        "motionplc.config.Machine",
        "motionplc.config.Machine.attach",
        "motionplc.runtime.Runtime.run_until",
        "motionplc.runtime.Runtime.run",
    ):
        assert full in runtime


def test_site_has_the_file_format_references_and_no_raw_rest(site: Path) -> None:
    for page in ("config", "sequence", "register_map"):
        assert (site / "reference" / f"{page}.html").is_file()
    if (ROOT / "docs" / "reference" / "gcode.md").is_file():  # gcode's generated page
        assert (site / "reference" / "gcode.html").is_file()
        assert "reference/gcode.html" in (site / "index.html").read_text(encoding="utf-8")
    for page in sorted((site / "api").glob("*.html")):
        text = page.read_text(encoding="utf-8")
        assert not re.search(r":(func|class|meth|mod|attr|exc):", text), page.name
    # a docstring's text made it into the page, a code example as code
    planning = (site / "api" / "planning.html").read_text(encoding="utf-8")
    assert "Time-optimal profile from" in planning
    assert "from motionplc.planning import plan_batch" in planning


def test_a_broken_reference_fails_the_build(tmp_path: Path) -> None:
    """The same handler options on a page naming an object that does not exist: the strict
    build fails and names it (as a renamed function left in an API page would)."""
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "index.md").write_text("# API\n\n::: motionplc.planning.no_such_planner\n")
    (tmp_path / "mkdocs.yml").write_text(
        "site_name: t\nstrict: true\nplugins:\n  - mkdocstrings:\n      handlers:\n"
        f"        python:\n          paths: [{str(ROOT)!r}]\n"
    )
    run = mkdocs("-q", "-d", str(tmp_path / "site"), cwd=tmp_path)
    assert run.returncode != 0
    assert "motionplc.planning.no_such_planner" in run.stderr


def _roles() -> Any:
    spec = importlib.util.spec_from_file_location("rst_roles", ROOT / "docs/hooks/rst_roles.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_rest_roles_become_inline_code() -> None:
    conv = _roles().markdown_roles
    assert conv("see :func:`plan` and :class:`~motionplc.planning.paths.base.Path`") == (
        "see `plan` and `Path`"
    )
    assert conv(":py:meth:`Runtime.run_until` ok") == "`Runtime.run_until` ok"
    assert conv("Public API::\n\n    x = 1") == "Public API:\n\n    x = 1"
    assert conv("a `::` b and ``x::y``") == "a `::` b and ``x::y``"  # only a paragraph's end
