"""The bike node (CycloCARLA): smart trainer, wheel-speed sensor, steering, resistance, fork FFB.

The network-free core is `bike_loop.BikeLoop`: one `step` per loop tick composes the
single-track bicycle, the riding resistance → trainer command, and the fork feel.
"""
