"""The launcher's study runs: `carlaverse study run` as a child, its folder inside the config
dir, steered and read through the same control file and log the command line uses.

Plain Python (no NiceGUI): `panel_study` is a thin view over it. A study file is read from the
config dir (or shipped); a run's folder is a path inside the config dir, like every file the
page may touch.
"""

from __future__ import annotations

from pathlib import Path

from carlaverse.config import ConfigError
from carlaverse.launcher.files import ConfigDir
from carlaverse.launcher.processes import LaunchError, Supervisor
from carlaverse.procs import Child
from carlaverse.study import control
from carlaverse.study.status import RunStatus, run_status

STUDY_CHILD = "study"  # the supervisor's name for the running study


class StudyRuns:
    """Starts one study run at a time and reads or steers the run in a folder."""

    def __init__(self, files: ConfigDir, supervisor: Supervisor) -> None:
        self.files = files
        self.supervisor = supervisor
        self.out: Path | None = None  # the folder of the run started or opened last

    def start(self, study_file: str, out_folder: str) -> Child:
        """`carlaverse study run FILE --out FOLDER`; LaunchError if a name is outside the
        config dir, or a study runs already."""
        running = self.supervisor.get(STUDY_CHILD)
        if running is not None and running.running:
            raise LaunchError("a study runs already: abort it, or wait until it ends")
        try:
            source = self.files.source(study_file)
            out = self.files.path(self.files.inside(out_folder))
        except ConfigError as exc:
            raise LaunchError(str(exc)) from exc
        out.mkdir(parents=True, exist_ok=True)
        self.out = out
        return self.supervisor.start(STUDY_CHILD, "study",
                                     ["study", "run", str(source), "--out", str(out)])  # fmt: skip

    def open(self, out_folder: str) -> None:
        """Follow the run in `out_folder` (one started earlier, from here or a terminal)."""
        try:
            self.out = self.files.path(self.files.inside(out_folder))
        except ConfigError as exc:
            raise LaunchError(str(exc)) from exc

    def status(self) -> RunStatus | None:
        """The followed run as its log has it; None before there is a log."""
        if self.out is None:
            return None
        try:
            return run_status(self.out)
        except FileNotFoundError:
            return None

    def send(self, command: str) -> None:
        """Hand the running study a command (pause, resume, abort, redo, note TEXT)."""
        if self.out is None:
            raise LaunchError("no study run is followed: start or open one first")
        try:
            control.send(self.out, command)
        except ValueError as exc:
            raise LaunchError(str(exc)) from exc
