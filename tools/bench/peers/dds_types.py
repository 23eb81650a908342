"""The IDL type of the DDS pose sample (imported only when CycloneDDS runs).

No `from __future__ import annotations` here: the binding reads the annotations as types.
"""

from dataclasses import dataclass

from cyclonedds.idl import IdlStruct, types

from carlaverse.messages import POSE_SIZE


@dataclass
class PoseBlob(IdlStruct, typename="carlaverse_bench::PoseBlob"):
    """The project's 64-byte pose as one octet array (copied as a block by the binding)."""

    data: types.array[types.uint8, POSE_SIZE]
