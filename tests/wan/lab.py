"""Several sites on one machine, joined by emulated WAN links (the WAN tests' harness; root).

    core namespace ── veth ── site a (10.99.1.2)  router a  <─ hub
         │  relays    ── veth ── site b (10.99.2.2)  router b  ── dials a through relay b
         │            ── veth ── site c (10.99.3.2)  router c  ── dials a through relay c

Each site is a network namespace with its own router (a `carlaverse router` process) that
listens on its WAN address and on the site's loopback, where the site's nodes connect. The
sites reach nothing but the core namespace (no forwarding there, no default routes), and
the core holds one `LinkEmulator` per spoke: a spoke's router dials its relay, the relay
dials the hub's router. So every byte between sites crosses an emulated link, and cutting a
link isolates that site, as a WAN outage would.

Router leases are longer than a node's (5 s by default): a WAN link must ride out a short
outage without dropping the far site's presence; the authority's despawn timeout decides.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from carlaverse import procs
from carlaverse.testing.linkemu import LinkEmulator, LinkProfile
from tests.wan.netns import (
    NamespaceSet,
    NetNamespace,
    Veth,
    enter_netns,
    owner_prefix,
    remove_orphans,
)

ROUTER_PORT = 7447
DEFAULT_ROUTER_LEASE_MS = 5000


@dataclass(frozen=True, slots=True)
class SitePlan:
    name: str
    index: int  # 1-based; the site's subnet is 10.99.<index>.0/24

    @property
    def address(self) -> str:
        return f"10.99.{self.index}.2"

    @property
    def core_address(self) -> str:
        return f"10.99.{self.index}.1"


class SiteProcess:
    """A child process inside a site's namespace (`carlaverse.procs`), output kept per stream."""

    MAX_LINES = 20000  # per stream: probes print a presence line per change

    def __init__(self, name: str, argv: list[str], log_dir: Path) -> None:
        self.name = name
        self.child = procs.start([], name=name, command=argv, max_lines=self.MAX_LINES)
        self.proc = self.child.proc
        self.log = log_dir / f"{name}.log"

    @property
    def lines(self) -> list[str]:
        """Its stderr lines so far."""
        return self.child.err.lines()

    @property
    def stdout(self) -> list[str]:
        """Its stdout lines so far."""
        return self.child.out.lines()

    def alive(self) -> bool:
        return self.child.running

    def said(self, text: str) -> bool:
        return any(text in line for line in self.lines + self.stdout)

    def stop(self, timeout: float = 15.0) -> int:
        code = self.child.stop(timeout)  # SIGINT, then SIGTERM and SIGKILL to its group
        # The process has exited, but its last lines (the exit summary) may still sit in the
        # pipes: read them to the end before anyone looks at the output.
        self.child.finish_reading(timeout)
        self.log.write_text("\n".join(self.lines + self.stdout) + "\n", encoding="utf-8")
        return code

    def output(self) -> str:
        return "\n".join(self.stdout)

    def json(self) -> Any:
        """The JSON document the process printed on stdout (its exit summary)."""
        document = procs.parse_json(self.stdout)
        if document is None:
            raise ValueError(f"{self.name} printed no JSON; stderr:\n{self.lines[-20:]}")
        return document

    def presence(self, target: str) -> list[tuple[bool, float]]:
        """A probe's presence changes of `target`: (present, monotonic time)."""
        out = []
        for line in list(self.lines):
            parts = line.split()
            if len(parts) == 4 and parts[0] == "presence" and parts[1] == target:
                out.append((parts[2] == "1", float(parts[3])))
        return out


class WanLab:
    """Sites in namespaces, a router each, spokes linked to the hub through link emulators."""

    def __init__(
        self,
        workdir: Path,
        sites: list[str],
        hub: str,
        profile: LinkProfile,
        router_lease_ms: int = DEFAULT_ROUTER_LEASE_MS,
        seed: int = 0,
    ) -> None:
        self.workdir = workdir
        self.plans = {name: SitePlan(name, i + 1) for i, name in enumerate(sites)}
        self.hub = self.plans[hub]
        self.profile = profile
        self.router_lease_ms = router_lease_ms
        self.seed = seed
        self.namespaces = NamespaceSet(owner_prefix(os.getpid()))
        self.links: dict[str, LinkEmulator] = {}
        self.processes: list[SiteProcess] = []
        self.routers: dict[str, SiteProcess] = {}

    # ------------------------------------------------------------ lifecycle

    def start(self, timeout: float = 30.0) -> WanLab:
        remove_orphans()
        try:
            core = self.namespaces.add("core")
            for plan in self.plans.values():
                site = self.namespaces.add(plan.name)
                Veth(
                    core, f"to-{plan.name}", plan.core_address, site, "wan0", plan.address
                ).create()
            for plan in self.spokes():
                self.links[plan.name] = self._link(plan, core)
            for plan in self.plans.values():
                self.routers[plan.name] = self._router(plan)
            self.wait(self._linked, timeout, "every spoke router to connect through its link")
        except BaseException:
            self.close()
            raise
        return self

    def close(self) -> None:
        for process in reversed(self.processes):
            process.stop()
        for link in self.links.values():
            link.close()
        self.namespaces.close()

    def __enter__(self) -> WanLab:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------ topology

    def spokes(self) -> list[SitePlan]:
        return [p for p in self.plans.values() if p != self.hub]

    def namespace(self, site: str) -> NetNamespace:
        return self.namespaces.spaces[site]

    def link(self, site: str) -> LinkEmulator:
        """The emulated link between `site` and the hub."""
        return self.links[site]

    def endpoint(self, site: str) -> str:
        """Where the nodes of `site` connect: the router on the site's loopback."""
        return f"tcp/127.0.0.1:{ROUTER_PORT}"

    def _link(self, plan: SitePlan, core: NetNamespace) -> LinkEmulator:
        return LinkEmulator(
            listen=(plan.core_address, 0),
            target=(self.hub.address, ROUTER_PORT),
            forward=self.profile,
            seed=self.seed + plan.index,
            thread_setup=lambda: enter_netns(core.name),
            name=f"{plan.name}-{self.hub.name}",
        ).start()

    def _router(self, plan: SitePlan) -> SiteProcess:
        fabric: dict[str, Any] = {
            "mode": "router",
            "listen": [f"tcp/{plan.address}:{ROUTER_PORT}", f"tcp/127.0.0.1:{ROUTER_PORT}"],
            "lease_ms": self.router_lease_ms,
        }
        if plan != self.hub:
            host, port = self.links[plan.name].address
            fabric["connect"] = [f"tcp/{host}:{port}"]
        config = self.workdir / f"router-{plan.name}.yaml"
        config.write_text(yaml.safe_dump({"fabric": fabric}), encoding="utf-8")
        return self.spawn(plan.name, f"router-{plan.name}", "router", "--config", str(config))

    def _linked(self) -> bool:
        for name, router in self.routers.items():
            if not router.alive():
                raise RuntimeError(f"router of site {name} exited:\n{router.output()}")
        return all(link.counts["accepted"] >= 1 for link in self.links.values())

    # ------------------------------------------------------------ processes

    def spawn(self, site: str, name: str, *args: str, script: Path | None = None) -> SiteProcess:
        """`python -m carlaverse args...` (or `python SCRIPT args...`) inside `site`'s
        namespace."""
        program = [str(script)] if script is not None else ["-m", "carlaverse"]
        argv = self.namespace(site).argv(sys.executable, *program, *args)
        process = SiteProcess(name, argv, self.workdir)
        self.processes.append(process)
        return process

    @staticmethod
    def wait(condition: Callable[[], bool], timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise TimeoutError(f"timed out after {timeout:.0f} s waiting for {what}")
            threading.Event().wait(0.05)


def write_scripted_config(
    path: Path,
    node_id: str,
    session: str,
    site: str,
    endpoint: str,
    path_spec: dict[str, Any],
    actor_kind: str = "car",
) -> Path:
    """A scripted node's YAML: it follows `path_spec` (`{"type": "circle", ...}`, see
    `carlaverse_nodes.scripted.trajectories`) and connects to `endpoint`."""
    config = {
        "node": {
            "node_id": node_id,
            "session": session,
            "kind": "scripted",
            "actor_kind": actor_kind,
            "site": site,
        },
        "fabric": {"connect": [endpoint]},
        "path": path_spec,
    }
    path.write_text(yaml.safe_dump(config, sort_keys=False), encoding="utf-8")
    return path
