"""A trial's recording sink: what a participant's machine is called stays out of it.

The recorder archives, beside each node's config, the host each node joined from
(`carlaverse.hostnames`). A participant's own machine is often named after its owner
("annas-laptop"), so in a study recording those values are withheld, keyed by pseudonym
still; the recorder's own host (`carlaverse.session`) is the lab's and is kept.
"""

from __future__ import annotations

from collections.abc import Mapping

from carlaverse.recording.archive import HOSTNAMES_METADATA
from carlaverse.study.lsl_sink import SharedSink

WITHHELD = "withheld (study recording)"


class TrialSink(SharedSink):
    """A SharedSink (LSL inlets may write into it too) with the participants' host names
    withheld."""

    def metadata(self, name: str, values: Mapping[str, str]) -> None:
        if name == HOSTNAMES_METADATA:
            values = dict.fromkeys(values, WITHHELD)
        super().metadata(name, values)
