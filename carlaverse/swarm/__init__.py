"""`carlaverse swarm`: a load generator, N synthetic egos in one process, each a joined node.

    generator    the swarm: one session, one publisher per ego key, one timer for all egos
    membership   joining, clocking and leaving for many egos on one Zenoh session
    paths        where the egos drive: loops around city blocks, for all egos at once

Nothing is imported here, so `carlaverse.swarm.paths` does not start Zenoh.
"""
