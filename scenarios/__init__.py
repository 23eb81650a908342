"""Scenarios shipped with CARLAverse (data only)."""
