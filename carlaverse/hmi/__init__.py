"""The web HMI: a node's dashboard, touchscreen and bike pages, served by the node itself.

`carlaverse join KIND --hmi PORT` serves them (carlaverse.cli.join_hmi); a node kind takes
part through `hmi_bridge()` (carlaverse.hmi.bridge). Starlette and uvicorn are imported only
inside this package.
"""
