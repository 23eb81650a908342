"""What every message shares: the schema version, the one decode error, and the constrained
wire types that keep a NaN, an infinity or an int64 overflow off the wire."""

from __future__ import annotations

from typing import Annotated

import msgspec

# 2: the snapshot's pose is the 64-byte pose layout; `spawned` carries the actor kind;
#    the `authority/leave` query; despawn reasons are a closed set.
# 3: spatial keys: poses on `ego/<id>/pose/<tile>`, NPC batches also per tile.
SCHEMA_VERSION = 3


class MessageError(ValueError):
    """A payload that does not decode into the expected message type."""


# Constrained wire types: a NaN, an infinity or an integer that overflows int64 is refused at
# decode time with the field's path, so no consumer (physics, recorder, renderer) ever sees one.
FLOAT_LIMIT = 1e15  # any physical quantity here is far smaller; NaN fails every bound
TIME_LIMIT_S = 1e12  # [s] session times are Unix-aligned (~1.7e9 s today)
Finite = Annotated[float, msgspec.Meta(ge=-FLOAT_LIMIT, le=FLOAT_LIMIT)]
Time = Annotated[float, msgspec.Meta(ge=-TIME_LIMIT_S, le=TIME_LIMIT_S)]  # [s] session time
Seq = Annotated[int, msgspec.Meta(ge=0, le=2**63 - 1)]
Int64 = Annotated[int, msgspec.Meta(ge=-(2**63), le=2**63 - 1)]
Vec3 = tuple[Finite, Finite, Finite]
