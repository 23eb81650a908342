"""The drive node (DrivoCARLA): controls, local car physics, steering feel and motion cueing.

The network-free core is `vehicle_loop.DriveLoop`: one `step(dt, raw_input, impulses)` per
loop tick composes controls → ADAS arbitration → car physics → steering feel → motion cueing.
"""
