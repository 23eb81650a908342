"""A command whose optional package is not installed says in one line which `pip install`
brings it, and exits 2 (README: "2 usage or config error"), never in a traceback.

"Not installed" is made real for every process of a command: a sitecustomize on PYTHONPATH
puts a finder first on `sys.meta_path` that answers each named package as pip would leave it
uninstalled (ModuleNotFoundError, `name` set), in the command and in any interpreter it
spawns. Which extra is right is read from pyproject.toml, not from the code under test: the
extra that lists the package's distribution among its own requirements.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
from functools import cache
from importlib import metadata
from pathlib import Path

import pytest
from PIL import Image

from carlaverse.cli.extras import EXTRA_OF_MODULE
from tests.support import free_port

ROOT = Path(__file__).resolve().parents[2]
EXTRAS: dict[str, list[str]] = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
    "optional-dependencies"
]
DEVELOPER_EXTRAS = {"test", "bench"}  # for working on carlaverse, not for running it
INSTALL = re.compile(r"pip install '?carlaverse\[([a-z,]+)\]'?")
NESTED = re.compile(r"carlaverse\[([a-z,]+)\]")  # an extra naming other extras
SITECUSTOMIZE = """
import os, sys
UNINSTALLED = set(os.environ["CARLAVERSE_TEST_UNINSTALLED"].split(","))
class Uninstalled:
    def find_spec(self, name, path=None, target=None):
        top = name.partition(".")[0]
        if top in UNINSTALLED:
            raise ModuleNotFoundError(f"No module named {top!r}", name=top)
        return None
sys.meta_path.insert(0, Uninstalled())
"""


@cache
def packages_distributions() -> dict[str, list[str]]:
    """Import name -> distributions, of what is installed here (a scan: once)."""
    return dict(metadata.packages_distributions())


def _normal(distribution: str) -> str:
    return re.sub(r"[-_.]+", "-", distribution).lower()


def listed_by(extra: str) -> set[str]:
    """The distributions an extra names itself (not through another extra)."""
    names = (re.split(r"[\s<>=!~;\[]", requirement, maxsplit=1)[0] for requirement in EXTRAS[extra])
    return {_normal(n) for n in names if n != "carlaverse"}


def extras_bringing(module: str) -> set[str]:
    distributions = {_normal(d) for d in packages_distributions().get(module, [])}
    return {extra for extra in EXTRAS if listed_by(extra) & distributions}


def run_uninstalled(tmp_path: Path, packages: str, *argv: str) -> subprocess.CompletedProcess[str]:
    site = tmp_path / "site"
    site.mkdir(exist_ok=True)
    (site / "sitecustomize.py").write_text(SITECUSTOMIZE)
    (tmp_path / "x.mcap").touch()  # a recording that exists: the import comes next
    path = os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")]))
    env = dict(os.environ, CARLAVERSE_TEST_UNINSTALLED=packages, PYTHONPATH=path)
    return subprocess.run([sys.executable, "-m", "carlaverse", *argv], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=90)  # fmt: skip


def nowhere() -> str:
    """An endpoint where no router answers (a free port), for commands that would connect."""
    return f"tcp/127.0.0.1:{free_port()}"


# (missing packages, the command line): each command that needs an extra, as far as the first
# package of that extra it imports. NOWHERE: an endpoint no router answers; FREE: a free port.
CASES = [
    ("pyarrow", "analyze x.mcap --out tables"),
    ("matplotlib", "analyze x.mcap --out tables"),
    ("scipy", "audio render x.mcap --listener a --out a.wav"),
    ("mcap", "audio render x.mcap --listener a --out a.wav"),
    ("mcap", "replay x.mcap --session s --connect NOWHERE"),
    ("mcap", "record --session s --out r.mcap --connect NOWHERE"),
    ("rerun", "view x.mcap --save v.rrd"),
    ("cryptography", "certs --out certs"),
    ("cv2", "body angles photo.png"),
    ("panda3d", "render s --out r.png --connect NOWHERE"),
    ("nicegui", "launcher --port FREE"),
    ("pygame", "doctor"),
    ("evdev", "ffb-server --backend evdev --port FREE --duration 1"),
    ("libsumo,sumolib", "authority --scenario town --session s --connect NOWHERE --duration 5"),
    ("panda3d", "join observer --id o --view --session s --connect NOWHERE --join-timeout 1"),
    (
        "starlette",
        "join drive --id d --backend sim --hmi FREE --session s --connect NOWHERE --join-timeout 1",
    ),
]


@pytest.mark.parametrize(("packages", "line"), CASES, ids=[f"{c.split()[0]}-{p}" for p, c in CASES])
def test_a_missing_extra_is_one_line_naming_its_install(
    tmp_path: Path, packages: str, line: str
) -> None:
    words = {"NOWHERE": nowhere, "FREE": lambda: str(free_port())}
    argv = [words[w]() if w in words else w for w in line.split()]
    done = run_uninstalled(tmp_path, packages, *argv)
    lines = done.stderr.strip().splitlines()
    assert "Traceback" not in done.stderr and len(lines) == 1, done.stderr[-3000:]
    assert lines[0].startswith(f"carlaverse {argv[0]}: "), lines
    named = INSTALL.search(lines[0])
    assert named, f"no `pip install 'carlaverse[EXTRA]'` in {lines[0]!r}"
    right = set().union(*(extras_bringing(p) for p in packages.split(",")))
    assert set(named[1].split(",")) & right, f"{lines[0]!r}: the extras listing it are {right}"
    assert done.returncode == 2, (done.returncode, lines)


def test_mediapipe_which_no_extra_lists_is_named_with_its_own_install(tmp_path: Path) -> None:
    # mediapipe is installed apart, without its dependencies (README "Body pose"): a readable
    # photograph gets `body angles` as far as the landmarker, which needs it.
    Image.new("RGB", (64, 64), (128, 128, 128)).save(tmp_path / "photo.png")
    done = run_uninstalled(tmp_path, "mediapipe", "body", "angles", "photo.png")
    lines = done.stderr.strip().splitlines()
    assert "Traceback" not in done.stderr and len(lines) == 1, done.stderr[-3000:]
    assert "pip install --no-deps 'mediapipe==" in lines[0], lines
    assert done.returncode == 2, (done.returncode, lines)


def test_the_table_names_the_extra_that_lists_each_package() -> None:
    wrong = {
        module: (extra, extras_bringing(module))
        for module, extra in EXTRA_OF_MODULE.items()
        if module in packages_distributions() and extra not in extras_bringing(module)
    }
    assert wrong == {}, "module: (table's extra, extras listing its distribution)"


def test_every_package_of_a_user_extra_is_in_the_table() -> None:
    # A package added to an extra without a row would die in a traceback when missing.
    in_table = {_normal(d) for m in EXTRA_OF_MODULE for d in packages_distributions().get(m, [])}
    installed = {_normal(d) for ds in packages_distributions().values() for d in ds}
    missing = {
        extra: sorted((listed_by(extra) & installed) - in_table)
        for extra in EXTRAS.keys() - DEVELOPER_EXTRAS
    }
    assert {e: m for e, m in missing.items() if m} == {}


def test_all_installs_every_extra_a_user_runs() -> None:
    # `all` names extras; what it installs is those and the extras they name in turn.
    def expand(extra: str) -> set[str]:
        nested = {n for r in EXTRAS[extra] if (m := NESTED.match(r)) for n in m[1].split(",")}
        return {extra}.union(*(expand(n) for n in nested))

    # carla needs a CARLA server; test and bench are for working on carlaverse
    assert expand("all") >= EXTRAS.keys() - DEVELOPER_EXTRAS - {"carla"}
