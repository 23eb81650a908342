"""A participant who stops being drawn during a live trial ends it `lost` after LOST_S (on a
manual clock), naming who; one drawn again in time does not."""

from __future__ import annotations

from pathlib import Path

from carlaverse.study.schedule import plan
from carlaverse.study.study_file import Condition, Participant, Study
from carlaverse.study.study_log import StudyLog
from carlaverse.study.trial import LOST_S, StudyContext, TrialRun


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


class Watch:
    """Stands in for the runner's view probe: who it draws from a live stream now."""

    def __init__(self) -> None:
        self.drawn = {"P01", "P02"}

    def sample(self) -> set[str]:
        return set(self.drawn)


def _trial(tmp_path: Path, clock: Clock) -> tuple[TrialRun, Watch]:
    study = Study(
        name="s",
        participants=[Participant(id="P01", role="driver"), Participant(id="P02", role="cyclist")],
        conditions=[Condition(id="direct")],
    )
    never = lambda *a: None  # noqa: E731 (the parts of the context this check does not use)
    ctx = StudyContext(study=study, study_dir=tmp_path, out=tmp_path,
                       log=StudyLog(tmp_path / "log.jsonl"), router="tcp/127.0.0.1:1",
                       links=None, set_brief=never, idle_briefs=never, spawn=never,  # type: ignore[arg-type]
                       take_command=never, stopped=lambda: False, say=never,
                       monotonic=clock)  # fmt: skip
    run = TrialRun(ctx, plan(study)[0], 1)
    watch = Watch()
    run._watch = watch  # type: ignore[assignment]
    run._last_seen = dict.fromkeys(run.roles, clock())
    return run, watch


def test_lost_after_lost_s_and_only_then(tmp_path: Path) -> None:
    clock = Clock()
    run, watch = _trial(tmp_path, clock)
    watch.drawn = {"P01"}
    clock.t += LOST_S  # exactly LOST_S unseen: not yet
    assert run._lost() is None
    clock.t += 0.1
    assert run._lost() == ("lost", f"P02 (cyclist) gone for {LOST_S:g} s")


def test_drawn_again_in_time_is_not_lost(tmp_path: Path) -> None:
    clock = Clock()
    run, watch = _trial(tmp_path, clock)
    watch.drawn = {"P01"}
    clock.t += LOST_S - 0.5
    assert run._lost() is None
    watch.drawn = {"P01", "P02"}
    assert run._lost() is None
    clock.t += LOST_S - 0.1  # LOST_S since each was last drawn has not passed
    assert run._lost() is None
