"""Node, authority and router configs shipped with CARLAverse (data only)."""
