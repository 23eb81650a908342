"""Pure test support shipped with the package: the link emulator, reference trajectories,
the renderer comparison and the in-process stream simulation.

It lives in the package because the test suite, the benchmark scripts in tools/ and probe
processes all import it from any working directory, without path edits. Nothing here needs
root or imports a node kind; the network-namespace harness lives in tests/wan/.
"""
