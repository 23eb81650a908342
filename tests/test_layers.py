"""The checks issue 41.6 asks of CI, run by pytest (which is what CI runs): the import contracts
of pyproject.toml's [tool.importlinter] (the layers of docs/architecture.md §13) hold, and the
tracked Python files are ruff clean and ruff formatted."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# lint-imports by module, not by the script on PATH: the one of this interpreter's packages
LINT_IMPORTS = (
    "import sys; from importlinter.cli import lint_imports_command as run; sys.exit(run())"
)


def tracked_python_files() -> list[str]:
    return subprocess.run(
        ["git", "ls-files", "*.py"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.split()


def test_the_import_contracts_hold() -> None:
    # lint-imports reads the contracts from pyproject.toml in its working directory and exits
    # 1 naming each import that breaks one (file and line).
    done = subprocess.run(
        [sys.executable, "-c", LINT_IMPORTS, "--no-cache"],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "0 broken" in done.stdout, done.stdout  # it checked contracts, not an empty list


def test_the_tree_is_ruff_clean() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "--quiet", *tracked_python_files()],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_tree_is_ruff_formatted() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "ruff", "format", "--check", *tracked_python_files()],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, "run `ruff format`:\n" + done.stdout + done.stderr


def test_the_architecture_diagram_is_the_contracts(tmp_path: Path) -> None:
    """docs/architecture.md §13 draws the layers from the contracts lint-imports checks: the
    document as committed is what the script writes, and the script really reads the
    contracts (a layer added to a copy of pyproject.toml appears in its output)."""
    done = subprocess.run(
        [sys.executable, "tools/layers_doc.py", "--check"],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        import layers_doc
    finally:
        sys.path.remove(str(ROOT / "tools"))
    changed = tmp_path / "pyproject.toml"
    bottom = '"carlaverse.support",\n]'
    deeper = '"carlaverse.support",\n    "carlaverse.bedrock",\n]'
    changed.write_text((ROOT / "pyproject.toml").read_text().replace(bottom, deeper, 1))
    drawn = layers_doc.region(layers_doc.contracts(changed))
    assert 'carlaverse_bedrock["bedrock"]' in drawn
    assert "carlaverse_support --> carlaverse_bedrock" in drawn
