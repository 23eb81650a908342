"""Keep a session and play it back
(docs/architecture.md §11): `carlaverse record` and `carlaverse replay`.

`encoding` maps samples to JSON-Schema'd MCAP messages that keep the original payload,
`sink` writes a crash-tolerant chunked MCAP file, `recorder` subscribes to a session and
feeds the sink from a bounded queue, `archive` fetches configs/scenario/map from the
authority, `recover` rewrites a killed recorder's file, `replay` republishes a recording,
`reading` iterates a recording, `timeline` puts its samples on the session clock, and
`synthetic` publishes a scripted session for tests and benchmarks.
"""
