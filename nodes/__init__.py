"""Node kinds shipped with CARLAverse, installed as `carlaverse_nodes` (see pyproject)."""
