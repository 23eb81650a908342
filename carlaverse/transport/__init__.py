"""The transport: how a node takes part in a session over Zenoh (docs/architecture.md §2, §7).

    settings      the `node:` and `fabric:` settings of a config (no Zenoh imported)
    session       opening Zenoh sessions from typed settings
    node_client   NodeClient: everything a node does on the fabric, behind one object
    inbound       the node's subscriptions: decode, check the sender, count, hand over
    guard         Zenoh callbacks that never raise
    interest      tiles a node hears and publishes in
    clock         the session clock, kept in step with the authority's
    waiting       saying what a node still waits for (router, authority)

What it receives for the world view it hands over through the view's intake
(`carlaverse.world.intake`, the one way in): the world model never imports the transport.
"""
