"""The project's modules import one way: irl_core <- render <- keys, widgets <- screens <- app, web <-
commands <- cli; no cycle anywhere, one module touches Textual's private API, and the play
session (`irl_core.play`) imports no front end, so a browser can drive it as the terminal does.
Within irl_core, the wings import one way too, and `irl_core.errors` (every exception) imports nothing.

The graph is read from the source with `ast`, imports inside functions included, so a cycle
cannot hide behind a late import.
"""

from __future__ import annotations

import ast
from pathlib import Path

import textual

ROOT = Path(__file__).parents[2]
PACKAGES = ("irl_core", "careful_tui")

# Lower may not import higher. Modules of careful_tui that no prefix names are checked for
# cycles only.
LAYERS = (
    ("irl_core", 0),
    ("careful_tui.errors", 1),
    ("careful_tui.version", 1),
    ("careful_tui.arguments", 1),
    ("careful_tui.option_words", 1),
    ("careful_tui.render", 2),
    ("careful_tui.keys", 3),
    ("careful_tui.widgets", 4),
    ("careful_tui.screens", 5),
    ("careful_tui.app", 6),
    ("careful_tui.web", 6),
    ("careful_tui.commands", 7),
    ("careful_tui.cli", 8),
    ("careful_tui.entry", 9),
)


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def project_modules() -> dict[str, Path]:
    return {module_name(path): path for package in PACKAGES for path in sorted((ROOT / package).rglob("*.py"))}


def imported_names(path: Path, module: str) -> set[str]:
    """Every module `path` imports, anywhere in the file (`from a import b` counts a.b when it is a module)."""
    names: set[str] = set()
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join([*package.split(".")[: len(package.split(".")) - node.level + 1], base]).strip(".")
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)
    return names


def import_graph() -> dict[str, set[str]]:
    modules = project_modules()
    return {module: imported_names(path, module) & modules.keys() - {module} for module, path in modules.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """A cycle as a list of modules (first repeated at the end), or None."""
    state: dict[str, str] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = "open"
        stack.append(node)
        for target in sorted(graph[node]):
            if state.get(target) == "open":
                return [*stack[stack.index(target):], target]
            if target not in state and (cycle := visit(target)):
                return cycle
        state[node] = "done"
        stack.pop()
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def layer(module: str) -> int | None:
    for prefix, rank in LAYERS:
        if module == prefix or module.startswith(prefix + "."):
            return rank
    return None


def test_the_cycle_finder_finds_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycle_among_the_projects_modules():
    graph = import_graph()
    assert "careful_tui.screens.play" in graph and "irl_core.worlds.mdp" in graph["irl_core.play.game"]
    assert find_cycle(graph) is None


def test_imports_run_one_way_down_the_layers():
    upward = [
        f"{module} imports {target}"
        for module, targets in import_graph().items()
        for target in targets
        if layer(module) is not None and layer(target) is not None and layer(target) > layer(module)
    ]
    assert upward == []


def test_no_command_imports_the_command_line():
    # Only the console script's wrapper above it, which says which extra to install when it cannot.
    importers = [module for module, targets in import_graph().items() if "careful_tui.cli" in targets]
    assert importers in ([], ["careful_tui.entry"])


def test_render_imports_no_textual():
    modules = project_modules()
    textual_users = [module for module, path in modules.items() if module.startswith("careful_tui.render")
                     and any(name.split(".")[0] == "textual" for name in imported_names(path, module))]
    assert textual_users == []


FRONT_ENDS = ("textual", "rich", "careful_tui")


def test_the_play_session_and_the_rest_of_the_core_import_no_front_end():
    modules = project_modules()
    core = {module: path for module, path in modules.items() if layer(module) == 0}
    assert {"irl_core.play.session", "irl_core.studies.flow", "irl_core.play.input_modes",
            "irl_core.play.hold", "irl_core.play.calibration", "irl_core.recordings.replay_cursor"} <= core.keys()
    front_end_users = sorted(
        f"{module} imports {name}" for module, path in core.items()
        for name in imported_names(path, module) if name.split(".")[0] in FRONT_ENDS
    )
    assert front_end_users == []


def test_only_the_kitty_module_touches_textuals_private_api():
    private = sorted(
        module for module, path in project_modules().items()
        if any(name.startswith("textual._") for name in imported_names(path, module))
    )
    assert private == ["careful_tui.keys.kitty"]


def test_the_kitty_module_was_written_for_the_installed_textual():
    # Its docstring lists the private API it touches and names the Textual release that list was read
    # against; a new Textual fails here, so that the list is re-read before the pin moves.
    import re

    docstring = ast.get_docstring(ast.parse((ROOT / "careful_tui" / "keys" / "kitty.py").read_text(encoding="utf-8")))
    named = re.findall(r"[Tt]extual(?: |==)(\d+\.\d+\.\d+)", docstring or "")
    assert named and set(named) == {textual.__version__}


# irl_core's wings, lowest first: a module may import its own wing and those before it.
WINGS = ("support", "worlds", "recordings", "play", "players", "reach", "irl", "coverage", "experiment", "studies")
# Below every wing, beside them: the one tree of exceptions, which imports nothing of the project.
BELOW_THE_WINGS = ("irl_core.errors",)


def wing(module: str) -> int | None:
    parts = module.split(".")
    return WINGS.index(parts[1]) if parts[0] == "irl_core" and len(parts) > 1 and parts[1] in WINGS else None


def test_irl_core_holds_only_its_wings():
    loose = sorted(module for module in project_modules() if module.startswith("irl_core.") and wing(module) is None)
    assert loose == list(BELOW_THE_WINGS)
    assert {path.name for path in (ROOT / "irl_core").iterdir() if path.is_dir() and path.name != "__pycache__"} == set(WINGS)


def test_irl_core_imports_run_down_its_wings():
    upward = sorted(
        f"{module} imports {target}"
        for module, targets in import_graph().items()
        for target in targets
        if wing(module) is not None and wing(target) is not None and wing(target) > wing(module)
    )
    assert upward == []
    # The check can fail: a studies module importing the worlds wing is downward, the reverse is not.
    assert wing("irl_core.studies.report") > wing("irl_core.worlds.mdp")


def test_the_errors_module_imports_nothing_of_the_project():
    # So that every module of irl_core and careful_tui may import it (they do) without a cycle.
    graph = import_graph()
    assert {module: sorted(graph[module]) for module in BELOW_THE_WINGS} == {module: [] for module in BELOW_THE_WINGS}
    assert "irl_core.errors" in graph["irl_core.support.safe_files"] and "irl_core.errors" in graph["careful_tui.cli"]


def test_the_layout_page_lists_every_module_of_every_wing():
    import re

    page = (ROOT / "docs" / "layout.md").read_text(encoding="utf-8")
    rows = {row.split("|")[1].strip(" `/"): row.split("|")[2] for row in page.splitlines() if row.startswith("| `")}
    assert list(rows) == list(WINGS)
    missing = sorted(
        module for module in project_modules()
        if wing(module) is not None and module.count(".") == 2
        and not re.search(rf"`{module.split('.')[-1]}`", rows[module.split(".")[1]])
    )
    assert missing == []


def test_the_web_front_end_imports_no_screen_no_widget_and_no_textual():
    """The browser's server draws the participants' words from `irl_core.studies.words`, not from the
    terminal's screens: no module of careful_tui.web imports Textual, a screen or a widget, and importing the
    server and its command works in a process where Textual cannot be imported at all."""
    import subprocess
    import sys

    modules = project_modules()
    borrowed = sorted(f"{module} imports {name}" for module, path in modules.items() if module.startswith("careful_tui.web")
                      for name in imported_names(path, module)
                      if name.split(".")[0] == "textual" or name.startswith(("careful_tui.screens", "careful_tui.widgets")))
    assert borrowed == []
    code = (
        "import sys\n"
        "class Refuse:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'textual':\n"
        "            raise ImportError('textual is refused here')\n"
        "sys.meta_path.insert(0, Refuse())\n"
        "import careful_tui.web.server, careful_tui.commands.serve\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'textual'))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
