"""Structure of ``workflows/``: scenes are thin and independent (issue 11).

A scene is ``workflows/<name>.py`` whose name does not start with ``_``; ``_cli.py`` and
``_plots.py`` are helper modules of the scenes. Checked (by parsing the sources with
:mod:`ast`, nothing is imported or run):

- no scene imports another scene (shared code lives in the packages or the helper modules);
- no test imports a scene (tests run scenes as subprocesses, ``tests/_workflows.py``).

- every scene has under :data:`MAX_LOGIC_LINES` lines of logic, i.e. the code lines (no
blank, comment or docstring lines) of its functions other than argument handling and plotting
(see :data:`CLI_OR_PLOT`), the issue's target. Print the table with
``python tests/test_workflow_structure.py``.
"""

from __future__ import annotations

import ast
import io
import os
import tokenize

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WORKFLOWS = os.path.join(ROOT, "workflows")
TESTS = os.path.join(ROOT, "tests")
#: Issue 11's target: a scene has fewer lines of logic than this.
MAX_LOGIC_LINES = 100
#: Functions not counted: argument handling (exact names) and plotting (name prefixes). ``main``
#: is counted: it is where a scene's calls and writing live, so logic hidden there shows.
CLI_OR_PLOT = {"names": ("build_parser", "validate"),
               "prefixes": ("plot", "draw", "_plot")}


def scenes() -> list[str]:
    """Module names of the scenes (``workflows/*.py`` not starting with ``_``)."""
    return sorted(f[:-3] for f in os.listdir(WORKFLOWS)
                  if f.endswith(".py") and not f.startswith("_"))


def _tree(path: str) -> ast.Module:
    with open(path) as fh:
        return ast.parse(fh.read(), filename=path)


def imported_modules(path: str) -> set[str]:
    """Top-level names of every module imported anywhere in a file (absolute imports)."""
    names: set[str] = set()
    for node in ast.walk(_tree(path)):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
        elif (isinstance(node, ast.Call) and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)
              and getattr(node.func, "attr", getattr(node.func, "id", None))
              in ("import_module", "__import__")):
            names.add(node.args[0].value.split(".")[0])
    return names


def _code_lines(source: str) -> set[int]:
    """Line numbers holding code: not blank, not only a comment."""
    lines: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type not in (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT,
                            tokenize.DEDENT, tokenize.ENDMARKER):
            lines.update(range(tok.start[0], tok.end[0] + 1))
    return lines


def _is_cli_or_plot(name: str) -> bool:
    return name in CLI_OR_PLOT["names"] or name.startswith(CLI_OR_PLOT["prefixes"])


def logic_lines(path: str) -> dict[str, int]:
    """Lines of logic per function of a scene (module-level functions and class methods).

    Code lines (:func:`_code_lines`) from the ``def`` line to the end of the function,
    docstrings excluded; argument handling and plotting (:data:`CLI_OR_PLOT`) are left out.
    """
    with open(path) as fh:
        source = fh.read()
    code = _code_lines(source)
    tree = ast.parse(source, filename=path)
    funcs = [n for n in tree.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
    for cls in (n for n in tree.body if isinstance(n, ast.ClassDef)):
        funcs += [n for n in cls.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
    out = {}
    for fn in funcs:
        if _is_cli_or_plot(fn.name):
            continue
        start = min([fn.lineno] + [d.lineno for d in fn.decorator_list])
        lines = {i for i in code if start <= i <= fn.end_lineno}
        for node in ast.walk(fn):
            body = getattr(node, "body", None)
            if (isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
                    and body and isinstance(body[0], ast.Expr)
                    and isinstance(body[0].value, ast.Constant)
                    and isinstance(body[0].value.value, str)):
                lines -= set(range(body[0].lineno, body[0].end_lineno + 1))
        out[fn.name] = len(lines)
    return out


def size_table() -> list[tuple[str, int, str]]:
    """Per scene: lines of logic and the largest three functions, as printed rows."""
    rows = []
    for name in scenes():
        per_fn = logic_lines(os.path.join(WORKFLOWS, f"{name}.py"))
        top = sorted(per_fn.items(), key=lambda kv: -kv[1])[:3]
        rows.append((name, sum(per_fn.values()), ", ".join(f"{k} {v}" for k, v in top)))
    return rows


def print_size_table() -> None:
    """Print :func:`size_table` (target of issue 11: under 100 lines of logic per scene)."""
    print(f"{'scene':<18} {'logic lines':>11}  largest functions")
    for name, total, top in size_table():
        flag = "" if total < MAX_LOGIC_LINES else f"  (>= {MAX_LOGIC_LINES})"
        print(f"{name:<18} {total:>11}  {top}{flag}")


@pytest.mark.serial
def test_no_scene_imports_a_scene():
    """Scenes share code through the packages and ``_cli``/``_plots``, never each other."""
    names = set(scenes())
    assert len(names) >= 5  # the listing found the scenes
    bad = {s: sorted(imported_modules(os.path.join(WORKFLOWS, f"{s}.py")) & (names - {s}))
           for s in sorted(names)}
    assert not {s: v for s, v in bad.items() if v}, bad
    print()
    print_size_table()


@pytest.mark.serial
def test_every_scene_is_thin():
    """Under :data:`MAX_LOGIC_LINES` lines of logic per scene (issue 11)."""
    rows = size_table()
    assert len(rows) >= 5
    fat = [(name, total, top) for name, total, top in rows if total >= MAX_LOGIC_LINES]
    assert not fat, fat


@pytest.mark.serial
def test_the_size_measure_can_fail(tmp_path):
    """Code in ``main`` and helpers counts; argument handling, plots and docstrings do not."""
    body = "".join(f"    x{i} = {i}\n" for i in range(60))
    src = tmp_path / "scene.py"
    src.write_text(f'def main():\n    """Doc.\n\n    More doc.\n    """\n{body}\n'
                   f"def helper():\n    # a comment\n{body}"
                   f"def build_parser():\n{body}def plot_it():\n{body}")
    per_fn = logic_lines(str(src))
    assert per_fn == {"main": 61, "helper": 61}
    assert sum(per_fn.values()) >= MAX_LOGIC_LINES


@pytest.mark.serial
def test_no_test_imports_a_scene():
    """Tests use the packages and run scenes as subprocesses (``tests/_workflows.py``)."""
    names = set(scenes())
    bad = {}
    for f in sorted(os.listdir(TESTS)):
        if f.endswith(".py"):
            hit = imported_modules(os.path.join(TESTS, f)) & names
            if hit:
                bad[f] = sorted(hit)
    assert not bad, bad


@pytest.mark.serial
def test_the_import_check_can_fail(tmp_path):
    """The checker sees every import form a scene could be pulled in by."""
    src = tmp_path / "x.py"
    src.write_text("import os\nimport mode_shape as m\nfrom figures import draw\n"
                   "def f():\n    import sweep_k.sub\n    importlib.import_module('benchmark')\n"
                   "from analytic import phase_diagram\n")
    assert imported_modules(str(src)) >= {"mode_shape", "figures", "sweep_k", "benchmark"}
    assert "phase_diagram" not in imported_modules(str(src))  # analytic.physics.phase_diagram



@pytest.mark.serial
def test_every_resumable_scene_resumes_through_parts():
    """One resume mechanism (``workflows/_parts.py``): a scene opened with ``resumable=True``
    calls ``run.parts`` (the time domain through ``_time_files``) and itself neither lists,
    tests, reads nor deletes files."""
    own = {"glob.glob", "os.listdir", "os.remove", "os.path.exists", "open", "json.load",
           "csv.DictReader"}
    seen = {}
    for name in scenes():
        path = os.path.join(WORKFLOWS, f"{name}.py")
        with open(path) as fh:
            if "resumable=True" not in fh.read():
                continue
        calls = {ast.unparse(n.func) for n in ast.walk(_tree(path)) if isinstance(n, ast.Call)}
        seen[name] = ("run.parts" in calls or "_time_files" in imported_modules(path),
                      sorted(calls & own))
    assert len(seen) >= 5 and seen == {s: (True, []) for s in seen}, seen

if __name__ == "__main__":
    print_size_table()
