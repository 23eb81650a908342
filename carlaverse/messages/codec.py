"""`Codec`: one message type's encoder and decoder, built once, raising only MessageError."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Generic, TypeVar

import msgspec

from carlaverse.messages.base import MessageError

T = TypeVar("T")


class Codec(Generic[T]):
    """Encoder and decoder for one message type, built once.

    `check` validates what the type system cannot say (a byte blob's length, the values packed
    in it); it runs on every decode and raises MessageError.
    """

    def __init__(self, type_: Any, check: Callable[[Any], None] | None = None) -> None:
        self.type = type_
        self._check = check
        self._encoder = msgspec.msgpack.Encoder()
        self._decoder = msgspec.msgpack.Decoder(type_)

    def encode(self, msg: T) -> bytes:
        try:
            return self._encoder.encode(msg)
        except Exception as exc:  # OverflowError, UnicodeEncodeError, TypeError: all one case
            raise MessageError(f"{_type_name(self.type)} cannot be encoded: {exc}") from exc

    def decode(self, buf: bytes | bytearray | memoryview) -> T:
        try:
            message = self._decoder.decode(buf)
            if self._check is not None:
                self._check(message)
            return message
        except MessageError:
            raise
        except (msgspec.DecodeError, msgspec.ValidationError) as exc:
            raise MessageError(f"{_type_name(self.type)}: {exc}") from exc
        # Untrusted bytes can make msgspec raise more than its own errors (RecursionError on
        # deep nesting, UnicodeDecodeError, MemoryError on absurd lengths): to every caller
        # they are one thing, a payload that is not this message.
        except Exception as exc:
            raise MessageError(f"{_type_name(self.type)}: {type(exc).__name__}: {exc}") from exc


def _type_name(type_: Any) -> str:
    return getattr(type_, "__name__", None) or str(type_)
