"""Study files decode strictly: a typo, a bad pseudonym or an unknown participant is one error
naming the file and the field."""

from __future__ import annotations

from pathlib import Path

import pytest

from carlaverse.config import ConfigError
from carlaverse.study.study_file import load_study

GOOD = """
name: dyad
participants:
  - {id: P01, role: driver, kind: drive}
  - {id: P02, role: cyclist, kind: bike}
conditions:
  - {id: direct}
  - id: lagged
    latency: {P02: {delay_ms: 150, jitter_ms: 20, loss: 0.01}}
design: {order: latin, blocks: 2, practice: [direct]}
trial: {duration_s: 5}
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "study.yaml"
    path.write_text(text)
    return path


def test_good_file_loads(tmp_path: Path) -> None:
    study = load_study(_write(tmp_path, GOOD))
    assert [p.id for p in study.participants] == ["P01", "P02"]
    assert study.conditions[1].latency["P02"].delay_ms == 150


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (("P02, role: cyclist", "Alice, role: cyclist"), "$.participants[1].id"),
        (("P02, role: cyclist", "P02, role: cyclist, colour: red"), "colour"),
        (("{P02: {delay_ms", "{P09: {delay_ms"), "$.conditions[1].latency.P09"),
        (("practice: [direct]", "practice: [warmup]"), "$.design.practice[0]"),
        (("loss: 0.01", "loss: 1.5"), "$.conditions[1].latency[...].loss"),
        (("P02, role: cyclist", "P01, role: cyclist"), "$.participants[1]"),
        (("order: latin", "order: random"), "$.design.order"),
    ],
)
def test_bad_file_names_the_field(tmp_path: Path, edit: tuple[str, str], says: str) -> None:
    path = _write(tmp_path, GOOD.replace(*edit))
    with pytest.raises(ConfigError) as caught:
        load_study(path)
    message = str(caught.value)
    assert message.startswith(str(path)) and says in message
    assert "\n" not in message


def test_pseudonyms_refuse_names(tmp_path: Path) -> None:
    # a code of up to four letters then digits: a name has no digits, or too many letters
    for bad in ("Alice", "alice1", "P", "P01x", "P-01"):
        path = _write(tmp_path, GOOD.replace("P01, role: driver", f"'{bad}', role: driver"))
        with pytest.raises(ConfigError, match=r"participants\[0\]\.id"):
            load_study(path)


ASKING = (
    GOOD.replace("kind: drive}", "kind: drive, hmi_port: 0}").replace(
        "kind: bike}", "kind: bike, hmi_port: 8081}"
    )
    + "questionnaires: {after_trial: [ssq, raw-tlx], timeout_s: 300}\nlsl: {streams: [ECG]}\n"
)


def test_questionnaires_and_lsl_load(tmp_path: Path) -> None:
    study = load_study(_write(tmp_path, ASKING))
    assert study.questionnaires.after_trial == ["ssq", "raw-tlx"]
    assert [p.hmi_port for p in study.participants] == [0, 8081]
    assert study.lsl is not None and study.lsl.streams == ["ECG"] and study.lsl.markers
    assert load_study(_write(tmp_path, GOOD)).lsl is None  # no section: no LSL at all


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (("[ssq, raw-tlx]", "[ssq, sus]"), "$.questionnaires.after_trial[1]"),
        (("kind: bike, hmi_port: 8081}", "kind: bike}"), "$.participants[1].hmi_port"),
        (("lsl: {streams: [ECG]}", "lsl: {streams: [ECG], scope: planet}"), "$.lsl.scope"),
        (("lsl: {streams: [ECG]}", "lsl: {stream: [ECG]}"), "stream"),
        (("timeout_s: 300", "timeout_s: 0"), "$.questionnaires.timeout_s"),
    ],
)
def test_bad_questionnaires_or_lsl_name_the_field(
    tmp_path: Path, edit: tuple[str, str], says: str
) -> None:
    path = _write(tmp_path, ASKING.replace(*edit))
    with pytest.raises(ConfigError) as caught:
        load_study(path)
    message = str(caught.value)
    assert message.startswith(str(path)) and says in message
    assert "\n" not in message
