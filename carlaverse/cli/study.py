"""`carlaverse study`: check, plan and run a study; a participant's agent; steer a run.

carlaverse study validate STUDY.yaml
carlaverse study plan STUDY.yaml [--json]
carlaverse study run STUDY.yaml --out DIR [--people FILE] [--connect EP]
carlaverse study agent --study NAME --participant P01 --connect EP
carlaverse study control DIR pause|resume|abort|redo|note TEXT
carlaverse study export DIR [--to EXPORT] [--study STUDY.yaml]
"""

from __future__ import annotations

import argparse
import sys
import threading
from pathlib import Path

from carlaverse.cli import study_export
from carlaverse.cli.common import fail, print_json, say, stop_on_signals, tell
from carlaverse.cli.exit_codes import Exit
from carlaverse.config import ConfigError
from carlaverse.keys import KeySpaceError, check_token
from carlaverse.procs import ChildFailed, ParentWatch
from carlaverse.study import control
from carlaverse.study.schedule import Trial, plan, shared_conflict
from carlaverse.study.study_file import Study, load_study
from carlaverse.study.study_log import StudyLogError
from carlaverse.study.trial_setup import check_materials

EXIT_OF_OUTCOME = {
    "done": Exit.OK,
    "not_started": Exit.NOT_ADMITTED,
    "aborted": Exit.FAILED,
    "stopped": Exit.FAILED,
    "failed": Exit.FAILED,
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        "Studies: participants (pseudonyms), conditions and counterbalanced trials in a study "
        "file; each trial a fresh, recorded session; a study log that resumes after a crash."
    )
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    check = sub.add_parser("validate", help="check a study file, its scenarios and node configs")
    check.add_argument("file", type=Path, help="the study file (YAML)")
    schedule = sub.add_parser("plan", help="print every trial: participant x condition")
    schedule.add_argument("file", type=Path, help="the study file (YAML)")
    schedule.add_argument("--json", action="store_true", help="the plan as JSON")
    run = sub.add_parser("run", help="run the trials not yet completed in --out")
    run.add_argument("file", type=Path, help="the study file (YAML)")
    run.add_argument("--out", type=Path, required=True, help="output folder (log, recordings)")
    run.add_argument(
        "--connect", action="append", default=[], metavar="EP",
        help="an existing router (default: the study's, else one on loopback)",
    )  # fmt: skip
    run.add_argument(
        "--people", type=Path, metavar="FILE",
        help="pseudonym: person mapping (mode 0600, outside the study and output folders), "
        "to greet participants by name on this console only",
    )  # fmt: skip
    run.add_argument(
        "--link-bind", default="127.0.0.1", metavar="ADDR",
        help="where the participants' link relays listen (default loopback; a study whose "
        "participants' machines connect from elsewhere names this host's address)",
    )  # fmt: skip
    run.add_argument(
        "--backend", default=None,
        help="the nodes' devices (default: sim for a local launch, the real ones for an "
        "external one; '' for the real ones)",
    )  # fmt: skip
    agent = sub.add_parser("agent", help="a participant's agent: runs their node per trial")
    agent.add_argument("--study", required=True, help="the study's name")
    agent.add_argument("--participant", required=True, help="the participant's pseudonym")
    agent.add_argument("--connect", required=True, metavar="EP",
                       help="the participant's link (the runner prints it)")  # fmt: skip
    agent.add_argument("--hmi", type=int, metavar="PORT",
                       help="the node serves its web HMI on PORT (0: any free one), where the "
                       "participant answers the study's questionnaires")  # fmt: skip
    agent.add_argument("--exit-with-parent", action="store_true",
                       help="end when the process that started it ends (local launch)")  # fmt: skip
    status = sub.add_parser("status", help="where a run stands: each trial from its log")
    status.add_argument("out", type=Path, help="the run's output folder")
    status.add_argument("--json", action="store_true", help="as JSON")
    steer = sub.add_parser("control", help="steer a running study (pause, resume, abort ...)")
    steer.add_argument("out", type=Path, help="the run's output folder")
    steer.add_argument("command", nargs="+", help=f"one of {', '.join(control.COMMANDS)}")
    study_export.add_parser(sub)


def run(args: argparse.Namespace) -> int:
    action = {"validate": _validate, "plan": _plan, "run": _run, "agent": _agent,
              "status": _status, "control": _control,
              "export": study_export.run}[args.action]  # fmt: skip
    try:
        return action(args)
    except (ConfigError, StudyLogError, KeySpaceError) as exc:
        return fail("study", str(exc))


def _load(path: Path) -> tuple[Study, list[Trial]]:
    study = load_study(path)
    trials = plan(study)
    conflict = shared_conflict(study, trials)
    if conflict:
        raise ConfigError(str(path), conflict)
    check_materials(study, path.parent)
    return study, trials


def _validate(args: argparse.Namespace) -> int:
    study, trials = _load(args.file)
    tell(f"{args.file}: valid study {study.name}: {len(study.participants)} participants, "
         f"{len(study.conditions)} conditions, {len(trials)} trials")  # fmt: skip
    return Exit.OK


def _plan(args: argparse.Namespace) -> int:
    study, trials = _load(args.file)
    if args.json:
        print_json({"study": study.name, "trials": trials})
        return Exit.OK
    ids = [p.id for p in study.participants]
    width = max(8, *(len(c.id) for c in study.conditions))
    print(f"{'trial':<6} {'kind':<9} {'block':>5}  " + "  ".join(f"{pid:<{width}}" for pid in ids))
    for t in trials:
        cells = "  ".join(f"{t.conditions[pid]:<{width}}" for pid in ids)
        print(f"{t.id:<6} {t.kind:<9} {t.block:>5}  {cells}")
    return Exit.OK


def _run(args: argparse.Namespace) -> int:
    from carlaverse.cli.record_lsl import LSL_ERRORS
    from carlaverse.recording.sink import RecordingError
    from carlaverse.study.people import load_people
    from carlaverse.study.runner import RunSettings, StudyRunner
    from carlaverse.transport.session import FabricError

    study, _trials = _load(args.file)
    greet = {}
    if args.people is not None:
        greet = load_people(args.people, [args.file.parent, args.out],
                            [p.id for p in study.participants])  # fmt: skip
    stop = stop_on_signals()
    settings = RunSettings(
        args.file, args.out, list(args.connect), args.backend, greet, args.link_bind
    )
    runner = StudyRunner(study, settings, stop, say("study"))
    try:
        result = runner.run()
    except ChildFailed as exc:
        return fail("study", str(exc), Exit.FAILED)
    except FabricError as exc:  # the router named cannot be reached, a session not opened
        return fail("study", str(exc), Exit.FABRIC)
    except RecordingError as exc:
        return fail("study", str(exc), Exit.FAILED)
    except LSL_ERRORS as exc:  # pylsl or a stream the study file names is missing
        return fail("study", str(exc), Exit.FAILED)
    why = f" ({result.reason})" if result.reason else ""
    again = "" if result.outcome == "done" else f"; run again with --out {args.out} to resume"
    tell(f"carlaverse study: {result.outcome}: {result.completed} of {result.trials} trials "
         f"completed{why}{again}")  # fmt: skip
    if stop.is_set() and result.outcome != "done":
        return stop.exit_code()
    return EXIT_OF_OUTCOME.get(result.outcome, Exit.FAILED)


def _agent(args: argparse.Namespace) -> int:
    from carlaverse.study.agent import StudyAgent
    from carlaverse.transport.session import FabricError, FabricSettings, open_session

    check_token(args.study, "study name")
    check_token(args.participant, "participant")
    stop = stop_on_signals()
    if args.exit_with_parent:
        _watch_parent(stop)
    try:
        # a client: it reaches the others through the participant's link alone
        session = open_session(FabricSettings(mode="client", connect=[args.connect]), stop=stop)
    except FabricError as exc:
        return fail("study", str(exc), stop.exit_code() if stop.is_set() else Exit.FABRIC)
    agent = StudyAgent(session, args.study, args.participant, args.connect, say("study agent"),
                       hmi_port=args.hmi)  # fmt: skip
    tell(f"study agent of {args.participant} in study {args.study}, via {args.connect}")
    try:
        agent.run(stop)
    finally:
        session.close()
    return Exit.OK


def _watch_parent(stop: threading.Event) -> None:
    """Set `stop` when the parent ends (the agent is then re-parented)."""
    parent = ParentWatch()

    def watch() -> None:
        while not stop.wait(0.2):
            if parent.gone():
                stop.set()

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def _status(args: argparse.Namespace) -> int:
    from carlaverse.study.status import run_status

    try:
        status = run_status(args.out)
    except FileNotFoundError:
        return fail("study", f"{args.out}: no study log here (study-log.jsonl)")
    if args.json:
        print_json(status)
        return Exit.OK
    print(f"study {status.study}: {status.state}, {status.completed} of the trials begun "
          "completed")  # fmt: skip
    for row in status.trials:
        views = " ".join(f"{pair} {p95:.2f} m" for pair, p95 in row.view_p95_m.items())
        conditions = ",".join(f"{p}={c}" for p, c in row.conditions.items())
        print(f"{row.trial:<6} attempt {row.attempts}  {row.outcome:<11} {conditions}  "
              f"{row.started[11:19]}-{row.ended[11:19]}  {views}".rstrip())  # fmt: skip
    return Exit.OK


def _control(args: argparse.Namespace) -> int:
    try:
        command = control.send(args.out, " ".join(args.command))
    except ValueError as exc:
        return fail("study", str(exc))
    print(f"sent {command.name} to the study running into {args.out}", file=sys.stderr)
    return Exit.OK
