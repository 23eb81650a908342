"""Reading the replies to a Zenoh query: the first good one, why one failed, and whether Zenoh
itself ended the query (no one answered in time) rather than a queryable refusing it.

Beside `keys`, not in the transport: the recorder asks the authority too, and recordings are
read and written without the transport (pyproject's import contracts).
"""

from __future__ import annotations

import logging

import zenoh

log = logging.getLogger(__name__)

REASON_LIMIT = 300  # [bytes] of an error reply's reason kept: it goes into logs and messages


def ask(
    session: zenoh.Session, key: str, payload: bytes, timeout_s: float
) -> tuple[bytes | None, str]:
    """The first good reply's payload to a query on `key`, else None and the error reply's
    reason ("" when nobody answered in time, or the query could not be sent)."""
    error = ""
    try:
        for reply in session.get(key, payload=payload, timeout=timeout_s):
            if reply.ok is not None:
                return reply.ok.payload.to_bytes(), ""
            if timed_out(reply):  # nobody answered: not the queryable's word
                log.debug("query %s: no answer within %g s", key, timeout_s)
                continue
            error = reply_reason(reply.err)
            log.warning("query %s answered with an error: %s", key, error)
    except zenoh.ZError as exc:
        log.debug("query %s failed: %s", key, exc)
    return None, error


def timed_out(reply: zenoh.Reply) -> bool:
    """Whether an error reply is Zenoh's own "Timeout", not a queryable's answer.

    Zenoh ends a query that no queryable finished in time with an error reply "Timeout",
    from the querier's own session (no replier) or from the session that forwarded the query
    (its runtime, entity id 0; measured: a held query through a router, 2 s). A queryable
    replies under its own entity id, never 0, and the authority never says "Timeout".
    """
    if reply.err is None or reply.err.payload.to_bytes() != b"Timeout":
        return False
    return reply.replier_id is None or reply.replier_id.eid == 0


def reply_reason(err: zenoh.ReplyError | None) -> str:
    """The reason an error reply carries, as text (not the ReplyError's byte dump)."""
    if err is None:  # zenoh types `Reply.err` optional: a reply that is neither ok nor error
        return "error reply without a reason"
    reason = err.payload.to_bytes()[:REASON_LIMIT].decode("utf-8", errors="replace").strip()
    return reason or "error reply without a reason"
