"""Traffic: the engine that moves NPC vehicles and pedestrians, its maps and its scenarios.

`engine` is the seam (a `TrafficEngine` protocol, so a CARLA bridge can be added later);
`sumo_engine` implements it with Eclipse SUMO in-process through `libsumo`. Nothing here
imports libsumo at import time: only constructing a `SumoEngine` does.
"""
