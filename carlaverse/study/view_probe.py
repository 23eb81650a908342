"""A participant's view of the others, sampled through that participant's own link.

The probe is an observer in the trial's session, a Zenoh client of the participant's relay
(`carlaverse.study.links`), with the world view every node draws from (`NodeClient.world`,
the participant node's interpolation settings): what it shows of another participant at a
moment is what the participant's node, behind the same link, shows then. The runner samples
it a few times a second; `carlaverse.study.view_error` compares the samples with the truth.
"""

from __future__ import annotations

import zenoh

from carlaverse.study.view_error import ViewSample
from carlaverse.transport.clock import MonotonicClock
from carlaverse.transport.node_client import NodeClient, NodeSettings
from carlaverse.transport.session import FabricSettings, open_session
from carlaverse.world.remote_actor import InterpolationSettings

PROBE_PREFIX = "view-"  # a probe's node id: view-<participant>


def probe_id(participant: str) -> str:
    return f"{PROBE_PREFIX}{participant}"


class ViewProbe:
    """Observer of one participant's view; `sample` from the owner's thread."""

    def __init__(
        self, node_id: str, session_name: str, endpoint: str, others: set[str],
        interpolation: InterpolationSettings | None = None,
    ) -> None:  # fmt: skip
        """`node_id`: the probe's own id (`probe_id(participant)`); `others`: the ids whose
        drawing it samples; `interpolation`: how the participant's node draws them."""
        self.others = others
        self.samples: list[ViewSample] = []
        # a client: through the given endpoint alone (a peer would dial the others directly)
        self._session: zenoh.Session = open_session(
            FabricSettings(mode="client", connect=[endpoint])
        )
        settings = NodeSettings(
            node_id=node_id,
            session=session_name,
            kind="observer",
            actor_kind="",
            interpolation=interpolation or InterpolationSettings(),
        )
        self.client = NodeClient(self._session, settings, MonotonicClock()).start()

    def sample(self) -> set[str]:
        """Record where the view draws each other participant now; the ids it draws from a
        live stream (a stale actor is drawn where it was last heard of: still a sample of what
        the participant sees, but no sign that the other is there)."""
        self.client.update()
        now = self.client.now()
        drawn = set()
        for view in self.client.world.ego_views(now):
            if view.actor_id in self.others:
                self.samples.append(ViewSample(now, view.actor_id, view.x, view.y))
                if not view.stale:
                    drawn.add(view.actor_id)
        return drawn

    def close(self) -> None:
        self.client.close()
        self._session.close()
