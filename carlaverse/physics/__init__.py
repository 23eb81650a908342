"""Local ego physics: tyres, single-track chassis, powertrain, steering feel, motion cueing.

Pure scalar Python with no network and no clock of its own, so a node can run it at 1 kHz
and a test can drive it step by step. Reused by every wheeled node kind.
"""
