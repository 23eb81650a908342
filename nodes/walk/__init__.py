"""The walk node (WalkoCARLA): a pedestrian in VR or at a desktop, walking in the shared world.

A control loop of its own (`loop_process`) reads the headset and controllers (`carlaverse.hal.xr`)
or keyboard/gamepad, walks (`gait`, optionally kept on sidewalks and crossings by `walkable`)
and writes the walker's state to shared memory; the fabric side (`node`) publishes the pose as
a `pedestrian` and the body's joint angles from an optional skeleton source (`body`).
"""
