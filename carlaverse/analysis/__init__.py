"""After a session: what every road user did, and how close they came.

tracks       every road user's trajectory from a recording, on one fixed time grid
footprints   rectangles on the ground: time to first contact, distance apart
surrogate    TTC, time below threshold, gap, DRAC per pair; PET at path crossings; queues
             at standstill left out, DRAC beyond a tyre's friction flagged
lanes        which lane of the recorded map a road user was on, and the lanes it drove
export       Parquet and CSV tables, the summary
report       the map, trajectories and conflicts as PNG and HTML
run          one analysis of one recording (`carlaverse analyze`)
"""
