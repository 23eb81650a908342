"""Secrets out of what a recording keeps and what a replay serves (`carlaverse.redact`'s rule).

Nodes redact their own config before joining, but a recording may come from an older node,
or a forged `authority/configs` reply may carry anything; so the file writer and the replay
server apply the same rule again. Only `authority/configs` replies and YAML attachments hold
configs; every other payload passes untouched (and costs nothing: the check is per channel).
"""

from __future__ import annotations

from collections.abc import Mapping

import msgspec

from carlaverse import messages
from carlaverse.keys import KeySpaceError, parse
from carlaverse.recording.encoding import KeyFormat, payload_of
from carlaverse.redact import UNREADABLE, redact, redact_yaml


def holds_configs(key: str) -> bool:
    """True for the one key whose payloads carry node configs (`authority/configs`)."""
    try:
        parsed = parse(key)
    except KeySpaceError:
        return False
    return (parsed.area, parsed.channel) == ("authority", "configs")


def scrub_configs(payload: bytes) -> bytes:
    """A `ConfigsReply` payload with every config redacted; unchanged if nothing was secret.

    A payload that does not decode cannot be checked, so it is withheld (empty).
    """
    try:
        reply = messages.CONFIGS.decode(payload)
    except (ValueError, RecursionError):  # MessageError, bad UTF-8, deep nesting
        return b""
    nodes = {node_id: redact_yaml(text) for node_id, text in reply.nodes.items()}
    scenario = redact_yaml(reply.scenario_yaml) if reply.scenario_yaml else ""
    if nodes == reply.nodes and scenario == reply.scenario_yaml:
        return payload
    return messages.CONFIGS.encode(
        msgspec.structs.replace(reply, nodes=nodes, scenario_yaml=scenario)
    )


def scrub_envelope(key: str, data: bytes) -> bytes:
    """A recorded JSON envelope on `key` re-encoded from its scrubbed payload (`recover`)."""
    try:
        raw, kind = payload_of(data)
    except messages.MessageError:
        raw, kind = b"", "put"  # not an envelope: nothing in it can be checked, so none kept
    scrubbed = scrub_configs(raw) if kind == "put" else raw
    return data if scrubbed == raw else KeyFormat(key).encode(scrubbed, kind).data


def scrub_attachment(name: str, media_type: str, data: bytes) -> bytes:
    """YAML attachments (configs, scenario) redacted; anything else as it is."""
    if "yaml" not in media_type and not name.endswith((".yaml", ".yml")):
        return data
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return UNREADABLE.encode()
    return redact_yaml(text).encode()


def scrub_metadata(values: Mapping[str, str]) -> dict[str, str]:
    """Metadata with secret-named entries blanked (values are strings by MCAP's rule)."""
    return {str(k): str(v) for k, v in redact(dict(values)).items()}
