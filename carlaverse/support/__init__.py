"""Small helpers every layer may use:

    ratelog   logging at a bounded rate (a flood of bad packets cannot flood the log)
    stats     the percentile every report, test and benchmark takes
    angles    wrapping angles onto one turn
    tally     a counter several threads add to (drops by channel, errors by handler)

Each is written once, here, and imports nothing else of carlaverse, so a module of any layer
can use it without an arrow pointing up (docs/architecture.md §13).
"""
