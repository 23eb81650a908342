"""One trial: a fresh session with its authority and recorder, the participants' nodes briefed
into it, started when every role is present, run for its duration, then taken down.

In order: the recording opens first (so it holds the authority's first reliable puts), with
the trial's conditions as MCAP metadata (`carlaverse.study.trial`); the authority starts with
the trial's scenario and seed; each participant's link gets the trial's delay, jitter and
loss; the briefs name the trial, and each agent starts its participant's node; once every
participant is drawn by the runner's own view (present, poses flowing) the trial is live for
`trial.duration_s`, or until an end condition of its world (end_condition.py); then, if
it completed, each participant answers the study's questionnaires on their node's HMI
(`questionnaires.after_trial`, stored in OUT/answers.jsonl); then the briefs go idle (the
nodes leave), the authority stops, and the recording closes. With an `lsl:` section the
study's LSL streams are recorded into the trial's recording from its start to its end, with
`trial_start`/`trial_end` markers at the live phase's ends (lsl_session.py). A trial that
ends any other way (not completed) keeps its recording under
`<trial>.attempt<N>.<outcome>.mcap`, so `<trial>.mcap` is always a completed one.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgspec

from carlaverse import messages as m
from carlaverse.keys import Keys
from carlaverse.procs import Child, ChildFailed, stop_children
from carlaverse.recording.recorder import Recorder
from carlaverse.study.answers import ANSWERS_NAME, AnswerStore
from carlaverse.study.asking import QuestionnaireIncomplete, ask_all
from carlaverse.study.control import Command
from carlaverse.study.end_condition import EndCondition
from carlaverse.study.links import ParticipantLinks
from carlaverse.study.lsl_session import LslSession, describe
from carlaverse.study.questionnaires import find_questionnaire
from carlaverse.study.schedule import Trial, world_condition
from carlaverse.study.study_file import LinkCondition, Study
from carlaverse.study.study_log import COMPLETED, StudyLog
from carlaverse.study.trial_setup import interpolation_of, node_config, write_scenario
from carlaverse.study.trial_sink import TrialSink
from carlaverse.study.view_error import true_tracks, view_errors
from carlaverse.study.view_probe import ViewProbe, probe_id
from carlaverse.transport.session import FabricSettings, open_session, reachable

AUTHORITY_READY = "authority of session "  # what `authority` prints once it ticks
READY_TIMEOUT_S = 60.0  # [s] for the authority to tick (SUMO, the map) on a loaded host
LEAVE_TIMEOUT_S = 8.0  # [s] for the nodes to leave once the briefs go idle
LOOK_S = 0.05  # [s] between looks at presence and control while waiting
LOST_S = 3.0  # [s] a participant not drawn this long is lost (the trial is run again)
METADATA_NAME = "carlaverse.study.trial"
TRIALS_DIR = "trials"


@dataclass
class StudyContext:
    """What every trial of a run shares: the study, its folders, log, fabric and controls."""

    study: Study
    study_dir: Path
    out: Path
    log: StudyLog
    router: str  # the router endpoint the runner's own processes connect to
    links: ParticipantLinks
    set_brief: Callable[[m.TrialBrief], None]
    idle_briefs: Callable[[], None]
    spawn: Callable[[list[str], str], Child]  # (argv, name) -> a started child
    take_command: Callable[[], Command | None]
    stopped: Callable[[], bool]  # SIGINT/SIGTERM
    say: Callable[[str], None]
    backend: str = "sim"  # the node backend the agents are told ("" for the real devices)
    paused: bool = False  # an operator's pause: no next trial until resume
    monotonic: Callable[[], float] = time.monotonic  # [s] the clock presence is judged by
    lsl: LslSession | None = None  # the study's LSL streams and markers, prepared once
    stop: threading.Event = field(default_factory=threading.Event)  # set with `stopped`


class TrialRun:
    """One attempt at one trial; `run` returns its outcome."""

    def __init__(self, ctx: StudyContext, trial: Trial, attempt: int) -> None:
        self.ctx, self.trial, self.attempt = ctx, trial, attempt
        self.session = f"{ctx.study.name}-{ctx.log.state.run_id}-{trial.id}-a{attempt}"
        self.recording = ctx.out / TRIALS_DIR / f"{trial.id}.mcap"
        self.roles = {p.id: p.role for p in ctx.study.participants}
        by_id = {c.id: c for c in ctx.study.conditions}
        self.conditions = {pid: by_id[name] for pid, name in trial.conditions.items()}
        self.link_conditions: dict[str, LinkCondition] = {
            pid: c.latency.get(pid, c.link) for pid, c in self.conditions.items()
        }
        self.world = world_condition(ctx.study, trial)
        self._authority: Child | None = None
        self._probes: dict[str, ViewProbe] = {}
        self._watch: ViewProbe | None = None
        self._last_seen: dict[str, float] = {}  # [s] monotonic: when each was last drawn
        settings = ctx.study.trial
        self._end = EndCondition(settings.end_on_triggers, settings.end_on_contact)

    def run(self) -> str:
        scenario = write_scenario(
            self.world, self.ctx.study_dir, self.recording.with_suffix(".scenario.yaml")
        )
        self._log_start(scenario)
        self.ctx.links.apply(self.link_conditions)
        recorder, rec_session, sink = self._start_recorder(scenario)
        lsl = self.ctx.lsl
        if lsl is not None:  # inlets write into the sink beside the recorder, from now on
            lsl.start(rec_session, Keys(self.session), sink)
        events = None
        if self._end.wanted:  # the callback decodes and sets a flag, nothing more
            events = rec_session.declare_subscriber(
                Keys(self.session).world("events"),
                lambda sample: self._end.on_event(sample.payload.to_bytes()),
            )
        outcome, reason, figures = "failed", "", {}
        try:
            outcome, reason = self._run_live(scenario)
            if lsl is not None and self._watch is not None:
                lsl.trial_ended(self.trial.id, self._session_now(), attempt=self.attempt,
                                outcome=outcome)  # fmt: skip
            if outcome == COMPLETED:
                self._ask(rec_session)  # before the nodes leave: their HMIs show the forms
        except ChildFailed as exc:
            reason = str(exc)
        finally:
            self._take_down()
            if events is not None:
                events.undeclare()
            if lsl is not None:  # before the recorder closes the sink it writes into
                self.ctx.say(describe(lsl.stop()))
            recorder.stop()
            rec_session.close()
            self.ctx.links.apply({})
        if outcome == COMPLETED:
            figures = self._view_errors()
        else:
            self._set_aside(outcome)
        self.ctx.log.append("trial_end", trial=self.trial.id, attempt=self.attempt,
                            outcome=outcome, reason=reason, view_error=figures)  # fmt: skip
        self.ctx.say(_report(self.trial.id, outcome, reason, figures))
        return outcome

    # ------------------------------------------------------------ phases

    def _log_start(self, scenario: str) -> None:
        self.ctx.log.append(
            "trial_start", trial=self.trial.id, attempt=self.attempt, session=self.session,
            kind=self.trial.kind, block=self.trial.block, conditions=self.trial.conditions,
            links={pid: msgspec.to_builtins(c) for pid, c in self.link_conditions.items()},
            scenario=self.world.scenario, seed=self.world.seed, who=self.roles,
            recording=str(self.recording.relative_to(self.ctx.out)),
        )  # fmt: skip
        self.ctx.say(f"trial {self.trial.id} (attempt {self.attempt}): session {self.session}, "
                     f"scenario {Path(scenario).name}")  # fmt: skip

    def _start_recorder(self, scenario: str) -> tuple[Recorder, Any, TrialSink]:
        session = open_session(reachable(FabricSettings(connect=[self.ctx.router])))
        sink = TrialSink(self.recording, monotonic=time.monotonic)
        sink.metadata(METADATA_NAME, self._metadata(scenario))
        recorder = Recorder(session, Keys(self.session), sink)
        recorder.start()
        return recorder, session, sink

    def _metadata(self, scenario: str) -> dict[str, str]:
        links = {pid: msgspec.to_builtins(c) for pid, c in self.link_conditions.items()}
        return {
            "study": self.ctx.study.name, "trial": self.trial.id, "attempt": str(self.attempt),
            "kind": self.trial.kind, "block": str(self.trial.block), "session": self.session,
            "scenario": self.world.scenario, "seed": json.dumps(self.world.seed),
            "conditions": json.dumps(self.trial.conditions), "roles": json.dumps(self.roles),
            "links": json.dumps(links),
        }  # fmt: skip

    def _run_live(self, scenario: str) -> tuple[str, str]:
        argv = ["authority", "--session", self.session, "--connect", self.ctx.router,
                "--scenario", scenario]  # fmt: skip
        if self.world.seed is not None and scenario != "none":
            argv += ["--seed", str(self.world.seed)]
        self._authority = self.ctx.spawn(argv, f"authority {self.trial.id}")
        self._authority.wait_for_line(AUTHORITY_READY, READY_TIMEOUT_S)
        ids = set(self.roles)
        self._watch = ViewProbe("study-watch", self.session, self.ctx.router, ids)
        briefs = {pid: self._brief(pid) for pid in sorted(ids)}
        if self.ctx.study.trial.view_probe_hz > 0:
            for pid in ids:
                self._probes[pid] = ViewProbe(
                    probe_id(pid), self.session, self.ctx.links.endpoint(pid), ids - {pid},
                    interpolation_of(briefs[pid].node_config_yaml),
                )  # fmt: skip
        for brief in briefs.values():
            self.ctx.set_brief(brief)
        outcome = self._wait_present(ids)
        if outcome is not None:
            return outcome
        live_t = self._session_now()
        self.ctx.log.append("trial_live", trial=self.trial.id, attempt=self.attempt,
                            session_t=round(live_t, 3))  # fmt: skip
        if self.ctx.lsl is not None:
            self.ctx.lsl.trial_started(self.trial.id, live_t, attempt=self.attempt,
                                       conditions=json.dumps(self.trial.conditions))  # fmt: skip
        self._last_seen = dict.fromkeys(self.roles, self.ctx.monotonic())
        self.ctx.say(f"trial {self.trial.id} live: every role present")
        return self._live()

    def _brief(self, pid: str) -> m.TrialBrief:
        participant = next(p for p in self.ctx.study.participants if p.id == pid)
        link = self.link_conditions[pid]
        return m.TrialBrief(
            schema=m.SCHEMA_VERSION, study=self.ctx.study.name, participant=pid, active=True,
            trial=self.trial.id, attempt=self.attempt, session=self.session,
            kind=participant.kind, condition=self.trial.conditions[pid],
            duration_s=self.ctx.study.trial.duration_s,
            node_config_yaml=node_config(participant, self.conditions[pid], self.ctx.study_dir),
            backend=self.ctx.backend, delay_ms=link.delay_ms, jitter_ms=link.jitter_ms,
            loss=link.loss,
        )  # fmt: skip

    def _wait_present(self, ids: set[str]) -> tuple[str, str] | None:
        """None once everyone is drawn; else the outcome that ended the wait."""
        assert self._watch is not None
        deadline = time.monotonic() + self.ctx.study.trial.start_timeout_s
        while True:
            missing = ids - self._watch.sample()
            if not missing:
                return None
            ended = self._interrupted()
            if ended is not None:
                return ended
            if time.monotonic() > deadline:
                named = ", ".join(f"{pid} ({self.roles[pid]})" for pid in sorted(missing))
                timeout = self.ctx.study.trial.start_timeout_s
                return "not_started", f"not present within {timeout:g} s: {named}"
            time.sleep(LOOK_S)

    def _live(self) -> tuple[str, str]:
        s = self.ctx.study.trial
        period = 1.0 / s.view_probe_hz if s.view_probe_hz > 0 else LOOK_S
        end = time.monotonic() + s.duration_s
        next_probe = time.monotonic()
        while time.monotonic() < end:
            ended = self._interrupted() or self._lost()
            if ended is not None:
                return ended
            if self._end.met.is_set():
                return COMPLETED, self._end.reason
            if time.monotonic() >= next_probe:
                for probe in self._probes.values():
                    probe.sample()
                next_probe += period
            time.sleep(min(LOOK_S, max(0.0, min(end, next_probe) - time.monotonic())))
        return COMPLETED, ""

    def _lost(self) -> tuple[str, str] | None:
        """`lost` once a participant has not been drawn for LOST_S (their node or link went):
        the trial did not run as its conditions say, and is run again."""
        assert self._watch is not None
        now = self.ctx.monotonic()
        for pid in self._watch.sample():
            self._last_seen[pid] = now
        gone = sorted(p for p in self.roles if now - self._last_seen.get(p, now) > LOST_S)
        if not gone:
            return None
        named = ", ".join(f"{pid} ({self.roles[pid]})" for pid in gone)
        return "lost", f"{named} gone for {LOST_S:g} s"

    def _interrupted(self) -> tuple[str, str] | None:
        """An outcome if a signal or a control command ends the trial now."""
        if self.ctx.stopped():
            return "aborted", "the runner was stopped (SIGINT/SIGTERM)"
        command = self.ctx.take_command()
        if command is None:
            return None
        if command.name == "note":
            self.ctx.log.append("note", trial=self.trial.id, text=command.text)
        elif command.name in ("abort", "redo"):
            return ("aborted" if command.name == "abort" else "redo"), "operator's command"
        elif command.name in ("pause", "resume"):
            self.ctx.paused = command.name == "pause"
            self.ctx.log.append("paused" if self.ctx.paused else "unpaused", trial=self.trial.id)
            if self.ctx.paused:
                self.ctx.say("paused: the next trial waits for `resume`")
        return None

    def _session_now(self) -> float:
        assert self._watch is not None
        return float(self._watch.client.now())

    def _ask(self, session: Any) -> None:
        """Each of the study's questionnaires, asked of every participant's node at once; the
        answers are stored as they come. One that is not answered in full within its timeout
        (or before the runner is stopped) is logged with who is missing; the trial stays
        completed, its partial answers kept."""
        settings = self.ctx.study.questionnaires
        ids = sorted(self.roles)
        with AnswerStore(self.ctx.out / ANSWERS_NAME) as store:
            for name in settings.after_trial:
                form = find_questionnaire(name, self.ctx.study_dir, self.ctx.study.design.seed)
                self.ctx.say(f"trial {self.trial.id}: asking {form.id} of {', '.join(ids)}")
                missing: list[str] = []
                try:
                    ask_all(session, Keys(self.session), store, ids, form, self.trial.id,
                            settings.timeout_s, self.ctx.stop)  # fmt: skip
                except QuestionnaireIncomplete as exc:
                    missing = exc.missing
                    self.ctx.say(f"trial {self.trial.id}: {form.id} not answered in full "
                                 f"by {', '.join(missing)}")  # fmt: skip
                self.ctx.log.append("questionnaire", trial=self.trial.id, attempt=self.attempt,
                                    questionnaire=form.id, missing=missing)  # fmt: skip
                if self.ctx.stopped():
                    return

    def _take_down(self) -> None:
        self.ctx.idle_briefs()
        if self._watch is not None:
            deadline = time.monotonic() + LEAVE_TIMEOUT_S
            while self._watch.sample() and time.monotonic() < deadline:
                time.sleep(LOOK_S)
        for probe in [*self._probes.values(), *([self._watch] if self._watch else [])]:
            probe.close()
        if self._authority is not None:
            stop_children([self._authority])

    # ------------------------------------------------------------ after

    def _view_errors(self) -> dict[str, Any]:
        truth = true_tracks(self.recording, set(self.roles))
        figures = {pid: view_errors(p.samples, truth) for pid, p in self._probes.items()}
        return msgspec.to_builtins(figures)

    def _set_aside(self, outcome: str) -> None:
        if self.recording.exists():
            self.recording.rename(set_aside_name(self.recording, self.attempt, outcome))


def set_aside_name(recording: Path, attempt: int, outcome: str) -> Path:
    """Where an attempt's recording goes when the attempt did not complete."""
    return recording.with_name(f"{recording.stem}.attempt{attempt}.{outcome}.mcap")


def _report(trial: str, outcome: str, reason: str, figures: dict[str, Any]) -> str:
    """The trial's line for the operator: outcome, and each participant's view error."""
    text = f"trial {trial}: {outcome}" + (f" ({reason})" if reason else "")
    for pid, others in figures.items():
        for other, e in others.items():
            text += (f"; {pid} sees {other} off by p50 {e['p50_m']:.2f} m, "
                     f"p95 {e['p95_m']:.2f} m, max {e['max_m']:.2f} m")  # fmt: skip
    return text
