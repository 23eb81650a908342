"""Test infrastructure shipped with the package: the WAN link emulator and namespaced sites.

It lives in the package (not in tests/ or tools/) because the test suite, the benchmark
scripts in tools/bench/ and the probe processes started inside namespaces all import it,
from any working directory, without path edits.
"""
