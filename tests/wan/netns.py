"""Network namespaces for WAN tests: sites on one machine, isolated from it and each other.

Only namespaces created here are touched, and every address lives inside them — nothing is
added to the host's own network. Links are veth pairs created directly between two of our
namespaces (`ip -n A link add ... peer ... netns B`), so even the host's interface list is
left alone. Needs root and the `ip` tool; `unavailable_reason()` says why not, for skips.
"""

from __future__ import annotations

import ctypes
import os
import re
import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

CLONE_NEWNET = 0x40000000
NETNS_DIR = "/var/run/netns"

# A TCP echo server and a client, each one line of Python run inside a namespace.
ECHO_SERVER = (
    "import socket;s=socket.create_server(('{addr}',9000));print('listening',flush=True);"
    "c,_=s.accept();c.sendall(c.recv(64));c.close()"
)
ECHO_CLIENT = (
    "import socket,sys;c=socket.create_connection(('{addr}',{port}),timeout=3);"
    "c.sendall(b'hello');sys.stdout.write(c.recv(64).decode())"
)


class NetnsError(RuntimeError):
    """An `ip` command failed; the message carries the command and its stderr."""


def _ip(*args: str) -> str:
    argv = ["ip", *args]
    result = subprocess.run(argv, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise NetnsError(f"`{' '.join(argv)}` failed: {result.stderr.strip()}")
    return result.stdout


def unavailable_reason() -> str | None:
    """None if namespaces can be created here, else why not (for a pytest skip)."""
    if os.geteuid() != 0:
        return "network namespaces need root (run the WAN tests as root or in a container)"
    if shutil.which("ip") is None:
        return "the `ip` tool (iproute2) is not installed"
    probe = NetNamespace(f"cvprobe{os.getpid()}")
    try:
        probe.create()
    except NetnsError as exc:
        return f"cannot create a network namespace: {exc}"
    finally:
        probe.delete()
    return None


def enter_netns(name: str) -> None:
    """Move the calling *thread* into namespace `name` (network namespaces are per thread)."""
    libc = ctypes.CDLL(None, use_errno=True)
    fd = os.open(f"{NETNS_DIR}/{name}", os.O_RDONLY)
    try:
        if libc.setns(fd, CLONE_NEWNET) != 0:
            errno = ctypes.get_errno()
            raise NetnsError(f"setns({name}) failed: {os.strerror(errno)}")
    finally:
        os.close(fd)


@dataclass
class NetNamespace:
    name: str
    created: bool = False

    def create(self) -> NetNamespace:
        _ip("netns", "add", self.name)
        self.created = True
        _ip("-n", self.name, "link", "set", "lo", "up")
        return self

    def delete(self) -> None:
        if os.path.exists(f"{NETNS_DIR}/{self.name}"):
            _ip("netns", "delete", self.name)
        self.created = False

    def argv(self, *command: str) -> list[str]:
        """`command` run inside this namespace."""
        return ["ip", "netns", "exec", self.name, *command]

    def ip(self, *args: str) -> str:
        return _ip("-n", self.name, *args)


@dataclass
class Veth:
    """A point-to-point link between two namespaces, one /24 address on each end."""

    a: NetNamespace
    a_if: str
    a_addr: str
    b: NetNamespace
    b_if: str
    b_addr: str
    prefix: int = 24

    def create(self) -> Veth:
        self.a.ip("link", "add", self.a_if, "type", "veth", "peer", "name", self.b_if,
                  "netns", self.b.name)  # fmt: skip
        for ns, ifname, addr in (
            (self.a, self.a_if, self.a_addr),
            (self.b, self.b_if, self.b_addr),
        ):
            ns.ip("addr", "add", f"{addr}/{self.prefix}", "dev", ifname)
            ns.ip("link", "set", ifname, "up")
        return self


def owner_prefix(pid: int) -> str:
    """Namespace name prefix of the harness run by process `pid`: `cvw<pid>`."""
    return f"cvw{pid}"


def remove_orphans() -> list[str]:
    """Delete namespaces left by harness runs whose process is gone (a killed test run)."""
    removed = []
    for line in _ip("netns", "list").splitlines():
        name = line.split()[0] if line.strip() else ""
        match = re.fullmatch(r"cvw(\d+)-[\w.-]+", name)
        if match and not _alive(int(match.group(1))):
            NetNamespace(name).delete()
            removed.append(name)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@dataclass
class NamespaceSet:
    """Namespaces created together and deleted together, whatever happens in between."""

    prefix: str
    spaces: dict[str, NetNamespace] = field(default_factory=dict)

    def add(self, role: str) -> NetNamespace:
        ns = NetNamespace(f"{self.prefix}-{role}")
        ns.delete()  # a leftover of a killed run with the same name
        self.spaces[role] = ns.create()
        return ns

    def close(self) -> None:
        errors = []
        for ns in self.spaces.values():
            try:
                ns.delete()
            except NetnsError as exc:
                errors.append(str(exc))
        self.spaces.clear()
        if errors:
            raise NetnsError("; ".join(errors))


@contextmanager
def owned_namespaces(tag: str) -> Iterator[NamespaceSet]:
    """A test's namespaces (`cvw<pid><tag>-<role>`), deleted after it whatever happened; the
    test is skipped, saying why, where namespaces cannot be made."""
    reason = unavailable_reason()
    if reason:
        import pytest  # only tests call this; the lab's harness does not need pytest

        pytest.skip(reason)
    spaces = NamespaceSet(owner_prefix(os.getpid()) + tag)
    try:
        yield spaces
    finally:
        spaces.close()
