"""Size rules of the packages: no function in analytic/ or forms/ over MAX_FUNCTION_LINES.

A function's size is its physical lines from the first decorator (or ``def``) to its last line,
docstring and comments included, nested functions counted with the function that holds them
(and on their own). The forms/ functions that other work is splitting are allowed, with their
size today, until they are split: the allow-list may only shrink.
"""

import ast
import os
import re

import pytest

pytestmark = pytest.mark.serial  # reads source files: once is enough

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGES = ("analytic", "forms")
#: Issue 16: no function in the packages over this many lines.
MAX_FUNCTION_LINES = 80
#: ``path:qualified name`` -> lines measured when the rule came in (functions being split).
ALLOWED = {
}


def function_sizes(source: str) -> dict[str, int]:
    """Lines per function (qualified ``Class.method`` / ``outer.inner`` names) of a module."""
    out: dict[str, int] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef):
                    start = min([child.lineno] + [d.lineno for d in child.decorator_list])
                    out[name] = child.end_lineno - start + 1
                visit(child, f"{name}.")

    visit(ast.parse(source), "")
    return out


def package_functions() -> dict[str, int]:
    """``"path:name" -> lines`` for every function of the packages."""
    sizes: dict[str, int] = {}
    for pkg in PACKAGES:
        for folder, _, files in os.walk(os.path.join(ROOT, pkg)):
            for f in sorted(files):
                if f.endswith(".py"):
                    path = os.path.join(folder, f)
                    rel = os.path.relpath(path, ROOT).replace(os.sep, "/")
                    with open(path) as fh:
                        for name, n in function_sizes(fh.read()).items():
                            sizes[f"{rel}:{name}"] = n
    return sizes


def too_long(sizes: dict[str, int], allowed: dict[str, int]) -> list[str]:
    """Functions over the limit, beyond the allow-list's size for them."""
    return [f"{key}: {n} lines" for key, n in sorted(sizes.items())
            if n > MAX_FUNCTION_LINES and n > allowed.get(key, 0)]


def test_no_function_over_the_limit():
    bad = too_long(package_functions(), ALLOWED)
    assert not bad, f"functions over {MAX_FUNCTION_LINES} lines: {bad}"


def test_allow_list_only_shrinks():
    """An allowed function that was split (or removed) leaves the list."""
    sizes = package_functions()
    stale = [key for key, n in ALLOWED.items() if sizes.get(key, 0) <= MAX_FUNCTION_LINES]
    assert not stale, f"remove from ALLOWED (now within the limit or gone): {stale}"


def test_the_measure_can_fail():
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    source = f"class A:\n    @staticmethod\n    def long():\n{body}\n\n\ndef short():\n    pass\n"
    sizes = function_sizes(source.replace("\n    x", "\n        x"))
    assert sizes == {"A.long": MAX_FUNCTION_LINES + 2, "short": 2}
    assert too_long({"m.py:A.long": sizes["A.long"]}, {}) == [
        f"m.py:A.long: {MAX_FUNCTION_LINES + 2} lines"]
    assert too_long({"m.py:A.long": sizes["A.long"]}, {"m.py:A.long": 200}) == []


@pytest.mark.parametrize("pkg", PACKAGES)
def test_at_most_eight_modules_at_the_top_of_a_package(pkg):
    top = [f for f in os.listdir(os.path.join(ROOT, pkg)) if f.endswith(".py")]
    assert len(top) <= 8, sorted(top)


def tracker_references(source: str) -> list[str]:
    """Lines citing an issue number (of a tracker that is not in the repository)."""
    return [line.strip() for line in source.splitlines()
            if re.search(r"\bissues? \d+|\bissue #\d+", line, flags=re.IGNORECASE)]


def test_no_issue_numbers_in_analytic():
    """Comments explain, they do not narrate history."""
    found = []
    for folder, _, files in os.walk(os.path.join(ROOT, "analytic")):
        for f in files:
            if f.endswith(".py"):
                with open(os.path.join(folder, f)) as fh:
                    found += [f"{f}: {s}" for s in tracker_references(fh.read())]
    assert not found, found
    assert tracker_references('"""Two bodies (issue 9): the substrate."""') != []
