"""Map sources the shipped scenarios refer to (plain XML, OpenDRIVE)."""
