"""The world model: a node's picture of the session, whoever feeds it (docs/architecture.md §7).

    world_view      WorldView: remote egos and NPCs, lights, weather, despawns, one render time
    intake          WorldIntake: the one way into a world view, and the reasons actors leave
    source          WorldSource and SampleFeed: what writes into the intake (live, recorded,
                    synthetic)
    ego_streams     each remote ego's statistics and recent samples
    remote_actor    a jittery pose stream turned into smooth motion (past mode)
    present         present mode: an actor projected to now, corrections blended in
    npc_table       NPC batches kept as arrays, interpolated when asked
    interest_npcs   NPC streams per tile, drawn together
    stream_summary  per-stream statistics as reported

No Zenoh here, nor anything of `carlaverse.transport`: the same view serves a live session, a
recording and a test (an import contract in pyproject.toml holds it).
"""
