"""The scale benchmark's layout: the town, the swarm's map, where the probes stand, the
windows' timing. Shared by the orchestration (`bench_scale.py`) and the report's text
(`scale_report.section`), which describes the layout it measured."""

from __future__ import annotations

from carlaverse.authority.pose_digest import DIGEST_PERIOD_S

GRID_JUNCTIONS = 8  # per side (a larger generated town takes minutes to build its scenery)
BLOCK_M = 150.0  # [m] between junctions
ATTACH_M = 80.0  # [m] the fringe roads: junction A0 sits at (ATTACH_M, ATTACH_M)
TOWN_M = BLOCK_M * (GRID_JUNCTIONS - 1)  # [m] across the town's junctions
SPREAD_M = 4000.0  # [m] the swarm drives the blocks of a 4 km grid that holds the town
CENTRE = (ATTACH_M + TOWN_M / 2 + 7.0, ATTACH_M + TOWN_M / 2 + 3.0)  # [m] the probes
MATE_OFFSET_M = 30.0  # [m] north of the centre: probe-near's neighbour, whatever the swarm does
VEHICLES = 500
FILL_S = 30.0  # [s] for SUMO to insert the NPCs before anything is measured
SETTLE_S = 3.0  # [s] after the swarm or the hearing probes joined, before a window
NEAR_RADIUS_M = 200.0  # [m] probe-near's interest radius (the node default)
# [ms] the digest window runs once per relay period, the shipped one (2 ms) last
DIGEST_SWEEP_MS = (1.0, 5.0, DIGEST_PERIOD_S * 1e3)
SWEEP_SETTLE_S = 1.0  # [s] after the period changed, before its window
FLOOR_DRAIN_MS = 1.0  # [ms] how often `floor-ring` drains its ring (the digest's delay or less)
ROUNDS = 3  # hear-everything and digest windows at the largest N, alternating

SCENARIO = f"""name: scale-bench
seed: 1
map:
  generate:
    kind: grid
    grid: {{junctions: {GRID_JUNCTIONS}, length_m: {BLOCK_M:g}, attach_length_m: {ATTACH_M:g}}}
    lanes: 1
traffic:
  vehicles: {{count: {VEHICLES}, mix: {{car: 0.85, van: 0.1, truck: 0.05}}}}
  action_step_s: 0.2
"""
