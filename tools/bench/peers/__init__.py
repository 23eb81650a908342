"""Peers compared on one workload (tools/bench/bench_peers.py).

transport.py  what every transport provides (base class, the shared sample, helpers)
registry.py   name -> transport, imported lazily
pose_path.py, zenoh_bare.py, dds.py (+ dds_types.py), zmq_pubsub.py, mqtt.py, udp.py
              the transports
arrivals.py   a receiver's count and latencies
run.py        one run of one transport: processes, warm-up, measured window, CPU
report.py     rounds pooled into the table, the ratios, the target and the split
profile.py    py-spy on the pose path's publisher and a receiver
steps.py      the fabric's pose callback, step by step
"""
