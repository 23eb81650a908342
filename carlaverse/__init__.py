"""CARLAverse: a Zenoh-based fabric that lets several humans share one live traffic world."""

__version__ = "0.1.0"
