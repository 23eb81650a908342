"""`carlaverse study run`: a study's trials, one by one, resumed from its log after a crash.

The run owns, for all its trials: a router (unless the study or the command names one), one
link relay per participant (`links`), the briefs (`briefs`) and, when the study is launched
locally, one agent per participant (`agent`), which runs that participant's node on its
simulated devices. Each trial is a `TrialRun`. The output folder holds:

    OUT/study-log.jsonl            the study log (study_log.py)
    OUT/trials/<trial>.mcap        each completed trial's recording
    OUT/trials/<trial>.attempt<N>.<outcome>.mcap   an attempt that did not complete
    OUT/trials/<trial>.scenario.yaml   the scenario a trial ran (overrides merged)
    OUT/control-<time>-<pid>.cmd   commands waiting for the runner (control.py)
    OUT/.runner.lock               held while a runner runs into OUT (run_lock.py)
    OUT/.runner-children.json      the running runner's children (leftovers.py)

A run begun again on the same folder goes on from the first trial not completed; a trial a
kill interrupted is logged `killed` and run again as a new attempt.
"""

from __future__ import annotations

import secrets
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from carlaverse.procs import Child, free_port, stop_children
from carlaverse.procs import start as start_child
from carlaverse.study import control
from carlaverse.study.briefs import Briefer
from carlaverse.study.leftovers import ChildList
from carlaverse.study.links import ParticipantLinks
from carlaverse.study.lsl_api import LslNetwork
from carlaverse.study.lsl_session import LslSession
from carlaverse.study.run_lock import RunLock
from carlaverse.study.schedule import Trial, digest, plan
from carlaverse.study.study_file import Study
from carlaverse.study.study_log import COMPLETED, LOG_NAME, StudyLog, StudyLogError
from carlaverse.study.trial import TRIALS_DIR, StudyContext, TrialRun, set_aside_name
from carlaverse.transport.session import FabricSettings, open_session, reachable

ROUTER_READY = "router "  # what `router` prints once it listens
READY_TIMEOUT_S = 30.0  # [s]
PAUSE_LOOK_S = 0.2  # [s] between looks at the control file while paused
AGENT_SAYS = "carlaverse study agent: "  # how an agent's own lines begin
RUN_AGAIN = ("redo", "lost")  # outcomes after which the same trial runs again at once


@dataclass
class RunSettings:
    study_path: Path
    out: Path
    connect: list[str] = field(default_factory=list)  # a router; overrides the study's
    backend: str | None = None  # the nodes' devices; None: sim when launched locally, else real
    greet: dict[str, str] = field(default_factory=dict)  # pseudonym -> person, console only
    link_bind: str = "127.0.0.1"  # where the participants' relays listen


@dataclass(frozen=True)
class RunResult:
    outcome: str  # done | aborted | stopped | not_started | failed
    reason: str = ""
    completed: int = 0
    trials: int = 0


class StudyRunner:
    """Runs the trials not yet completed; `run` returns how the run ended."""

    def __init__(
        self, study: Study, settings: RunSettings, stop: threading.Event,
        say: Callable[[str], None],
    ) -> None:  # fmt: skip
        self.study, self.settings, self.stop, self.say = study, settings, stop, say
        self.trials = plan(study)
        self.out = settings.out
        (self.out / TRIALS_DIR).mkdir(parents=True, exist_ok=True)
        self.lock = RunLock(self.out).acquire()  # before the log is read (and a torn line cut)
        self.log = StudyLog(self.out / LOG_NAME)
        self.children_file = ChildList(self.out)
        self._children: list[Child] = []
        self._agents: list[Child] = []

    def run(self) -> RunResult:
        try:
            return self._run()
        finally:
            self.lock.release()

    def _run(self) -> RunResult:
        self._open_log()
        left = self.children_file.stop_leftovers()
        if left:
            self.say(f"stopped {left} processes a killed run had left")
        todo = [t for t in self.trials if t.id not in self.log.state.completed]
        if not todo:
            return self._result("done")
        lsl = self._lsl()  # before anything starts: a missing stream stops the run here
        router = self._router()
        links = ParticipantLinks(
            self.study.participants, router, self.settings.link_bind, self.study.design.seed
        )
        session = open_session(reachable(FabricSettings(connect=[router])))
        briefer = Briefer(session, self.study.name, [p.id for p in self.study.participants])
        try:
            links.start()
            briefer.start()
            self._start_agents(links)
            ctx = self._context(router, links, briefer)
            ctx.lsl = lsl
            return self._run_trials(ctx, todo)
        finally:
            briefer.close()
            stop_children(self._agents)
            session.close()
            links.close()
            stop_children(self._children)
            self.children_file.clear()

    # ------------------------------------------------------------ set-up

    def _open_log(self) -> None:
        state, fingerprint = self.log.state, digest(self.study)
        if state.events == 0:
            roles = {p.id: p.role for p in self.study.participants}
            # Sessions are named <study>-<run>-<trial>-a<attempt>: two runs of one study (two
            # groups, a run begun again in a new folder) never share a session, nor a node's
            # shared memory, which is named after its session.
            self.log.append("study", study=self.study.name, digest=fingerprint,
                            run_id=secrets.token_hex(3), trials=len(self.trials),
                            participants=roles)  # fmt: skip
            return
        if state.digest != fingerprint:
            raise StudyLogError(
                f"{self.log.path}: this log began under another version of the study file "
                f"(digest {state.digest}, the file now {fingerprint}): run into a new --out"
            )
        if state.open_trial is not None:
            trial, attempt = state.open_trial
            self.log.append("trial_end", trial=trial, attempt=attempt, outcome="killed",
                            reason="the runner ended during the trial", view_error={})  # fmt: skip
            partial = self.out / TRIALS_DIR / f"{trial}.mcap"
            if partial.exists():
                partial.rename(set_aside_name(partial, attempt, "killed"))
        self.log.append("resumed", completed=sorted(state.completed))

    def _lsl(self) -> LslSession | None:
        """The study's LSL streams found and its marker outlets' prefix set; None without LSL.
        LslUnavailable, LslConfigConflict or StreamMissing (one line naming the fix)."""
        wanted = self.study.lsl
        if wanted is None:
            return None
        network = LslNetwork(wanted.scope, wanted.session_id, tuple(wanted.known_peers))
        return LslSession.prepare(
            wanted.streams, network=network, wait_s=wanted.wait_s, markers=wanted.markers,
            stream_prefix=f"carlaverse-{self.study.name}-{self.log.state.run_id}",
        )  # fmt: skip

    def _router(self) -> str:
        connect = self.settings.connect or self.study.connect
        if connect:
            return connect[0]
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        router = self._spawn(["router", "--listen", endpoint], "router")
        router.wait_for_line(ROUTER_READY, READY_TIMEOUT_S, stream="out")
        return endpoint

    def _start_agents(self, links: ParticipantLinks) -> None:
        if self.study.launch != "local":
            for p in self.study.participants:
                self.say(f"{p.id} ({p.role}, {p.site}): run `carlaverse study agent "
                         f"--study {self.study.name} --participant {p.id} "
                         f"--connect {links.endpoint(p.id)}{_hmi_option(p.hmi_port)}` "
                         "on their machine")  # fmt: skip
            return
        for p in self.study.participants:
            argv = ["study", "agent", "--study", self.study.name, "--participant", p.id,
                    "--connect", links.endpoint(p.id), "--exit-with-parent"]  # fmt: skip
            if p.hmi_port is not None:
                argv += ["--hmi", str(p.hmi_port)]
            self._agents.append(self._spawn(argv, f"agent {p.id}", self._relay_agent))

    def _context(self, router: str, links: ParticipantLinks, briefer: Briefer) -> StudyContext:
        return StudyContext(
            study=self.study, study_dir=self.settings.study_path.parent, out=self.out,
            log=self.log, router=router, links=links, set_brief=briefer.set,
            idle_briefs=briefer.idle, spawn=self._spawn,
            take_command=lambda: control.take(self.out), stopped=self.stop.is_set,
            say=self.say, backend=self._backend(), stop=self.stop,
        )  # fmt: skip

    def _relay_agent(self, line: str) -> None:
        """An agent's own lines (its node joining, stopping, failing) on the run's console."""
        if line.startswith(AGENT_SAYS):
            self.say(line[len(AGENT_SAYS) :].strip())

    def _backend(self) -> str:
        if self.settings.backend is not None:
            return self.settings.backend
        return "sim" if self.study.launch == "local" else ""

    def _spawn(
        self, argv: list[str], name: str, on_stderr: Callable[[str], None] | None = None
    ) -> Child:
        child = start_child(argv, name=name, role=name.split()[0], on_stderr=on_stderr)
        self._children.append(child)
        self.children_file.add(child.proc.pid)
        return child

    # ------------------------------------------------------------ trials

    def _run_trials(self, ctx: StudyContext, todo: list[Trial]) -> RunResult:
        queue = list(todo)
        while queue:
            trial = queue[0]
            ended = self._wait_unpaused(ctx)
            if ended:
                return self._result(ended, f"{ended} before trial {trial.id}")
            self._greet(trial)
            attempt = self.log.state.attempts.get(trial.id, 0) + 1
            outcome = TrialRun(ctx, trial, attempt).run()
            self._children = [c for c in self._children if c.running]
            if outcome == COMPLETED:
                queue.pop(0)
            elif outcome not in RUN_AGAIN:
                return self._result(outcome, f"trial {trial.id} {outcome}")
        return self._result("done")

    def _wait_unpaused(self, ctx: StudyContext) -> str:
        """ "" once the next trial may start; else how the run ends (stopped, aborted)."""
        while not self.stop.is_set():
            command = control.take(self.out)
            if command is not None and command.name == "abort":
                return "aborted"  # nothing runs to abort: the run ends before the next trial
            if command is not None:
                self._between_trials(ctx, command)
            if not ctx.paused:
                return ""
            time.sleep(PAUSE_LOOK_S)
        return "stopped"

    def _between_trials(self, ctx: StudyContext, command: control.Command) -> None:
        if command.name == "note":
            self.log.append("note", trial="", text=command.text)
        elif command.name in ("pause", "resume"):
            ctx.paused = command.name == "pause"
            self.log.append("paused" if ctx.paused else "unpaused", trial="")

    def _greet(self, trial: Trial) -> None:
        """Who sits where, for the operator; the only place the pseudonym mapping is used."""
        for pid, condition in trial.conditions.items():
            person = self.settings.greet.get(pid)
            if person:
                self.say(f"{pid} is {person}: trial {trial.id}, condition {condition}")

    def _result(self, outcome: str, reason: str = "") -> RunResult:
        if outcome != "done" or self.stop.is_set():
            self.log.append("stopped", outcome=outcome, reason=reason)
        completed = len(self.log.state.completed)
        return RunResult(outcome, reason, completed, len(self.trials))


def _hmi_option(port: int | None) -> str:
    return "" if port is None else f" --hmi {port}"
