"""The pseudonym -> person mapping (issue 44.7): optional, kept apart, never recorded.

A lab that keeps the mapping at all keeps it in one file readable by its owner alone (mode
0600) outside the study folder and outside the run's output folder, so copying, sharing or
exporting either never carries it. The runner reads it only to greet the operator ("P01 is
Jane Doe: to the driving seat"); nothing of it goes into the study log, a brief or a
recording, which know pseudonyms alone.

    P01: Jane Doe
    P02: participant 2 of the Tuesday group
"""

from __future__ import annotations

import stat
from pathlib import Path

from carlaverse.config import ConfigError, parse_yaml, read_text


def load_people(path: Path, keep_out_of: list[Path], pseudonyms: list[str]) -> dict[str, str]:
    """The mapping in `path`; ConfigError if it is readable by others, lies inside any of
    `keep_out_of`, or names a pseudonym the study does not have."""
    if not path.is_file():
        raise ConfigError(str(path), "no such people file")
    mode = stat.S_IMODE(path.stat().st_mode)
    if mode & 0o077:
        raise ConfigError(
            str(path),
            f"readable by others (mode {mode:04o}): the pseudonym mapping must be the owner's "
            f"alone: chmod 600 {path}",
        )
    resolved = path.resolve()
    for folder in keep_out_of:
        if resolved.is_relative_to(folder.resolve()):
            raise ConfigError(
                str(path),
                f"lies inside {folder}: keep the pseudonym mapping outside the study and "
                "output folders, so that sharing them never shares it",
            )
    data = parse_yaml(read_text(path), str(path))
    if not isinstance(data, dict):
        raise ConfigError(str(path), "expected a mapping of pseudonym: person")
    people = {str(k): str(v) for k, v in data.items()}
    unknown = [pid for pid in people if pid not in pseudonyms]
    if unknown:  # not echoed: a reversed mapping (Jane Doe: P01) would print the name
        raise ConfigError(
            str(path),
            f"{len(unknown)} of its keys are no participant of the study: each line is "
            "PSEUDONYM: PERSON (P01: <their name>)",
        )
    return people
