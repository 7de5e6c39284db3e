"""The design notes are in the repository and every reference to them resolves (issue 11).

Scans the project's Python and Markdown files (not hidden folders, not results, not this
file, whose examples are wrong on purpose) as text: every
"design.md section N" names a numbered section ``## N.`` of ``docs/design.md``, no file cites
the old, absent top-level ``DESIGN.md``, and every relative Markdown link of the README and of
``docs/`` points to an existing file.
"""

from __future__ import annotations

import os
import re

import pytest

pytestmark = pytest.mark.serial  # reads files only

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DESIGN = os.path.join(ROOT, "docs", "design.md")
SKIP_DIRS = {".venv", ".git", "results", "__pycache__", "out"}
SECTION_REF = re.compile(r"design\.md,? section (\d+)")
OLD_REF = re.compile(r"(?<![/\w])DESIGN\.md")
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def project_files(exts: tuple[str, ...] = (".py", ".md")) -> list[str]:
    """Paths of the project's files with these extensions."""
    out = []
    for base, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if d not in SKIP_DIRS and not d.startswith(".")]
        out += [os.path.join(base, f) for f in files
                if f.endswith(exts) and os.path.join(base, f) != os.path.abspath(__file__)]
    return sorted(out)


def design_sections(path: str = DESIGN) -> set[int]:
    """Numbers of the ``## N. Title`` sections of the design notes."""
    with open(path) as fh:
        return {int(m.group(1)) for m in re.finditer(r"^## (\d+)\.", fh.read(), re.M)}


def bad_references(paths: list[str], sections: set[int]) -> list[tuple[str, str]]:
    """(file, reference) of every section reference that does not resolve and every old one."""
    bad = []
    for path in paths:
        with open(path, encoding="utf-8") as fh:
            text = fh.read()
        rel = os.path.relpath(path, ROOT)
        bad += [(rel, m.group(0)) for m in SECTION_REF.finditer(text)
                if int(m.group(1)) not in sections]
        if rel != os.path.join("docs", "design.md"):  # it explains the rename once
            bad += [(rel, m.group(0)) for m in OLD_REF.finditer(text)]
    return bad


def test_design_notes_exist_and_every_reference_resolves():
    sections = design_sections()
    assert set(range(1, 11)) <= sections
    paths = project_files()
    assert len(paths) > 50  # the walk found the project
    assert not bad_references(paths, sections)


def test_the_reference_check_can_fail(tmp_path):
    src = tmp_path / "x.py"
    src.write_text("# see docs/design.md section 4 and docs/design.md section 42; DESIGN.md\n")
    assert bad_references([str(src)], {4}) == [(os.path.relpath(str(src), ROOT),
                                                "design.md section 42"),
                                               (os.path.relpath(str(src), ROOT), "DESIGN.md")]


def test_relative_markdown_links_resolve():
    docs = [p for p in project_files((".md",))
            if os.path.dirname(p) in (ROOT, os.path.join(ROOT, "docs"))]
    missing = []
    for path in docs:
        with open(path, encoding="utf-8") as fh:
            for target in LINK.findall(fh.read()):
                if "://" in target or target.startswith("mailto:"):
                    continue
                if not os.path.exists(os.path.join(os.path.dirname(path), target)):
                    missing.append((os.path.relpath(path, ROOT), target))
    assert len(docs) >= 5
    assert not missing, missing
