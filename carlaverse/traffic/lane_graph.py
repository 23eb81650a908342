"""The map's lanes as a graph for one kind of road user: which lane leads to which.

Nodes are the lanes the kind may use, edges the map's connections (`MapLane.successors`, the
lane beyond each junction), less the turns that reverse the direction (a U-turn at a dead
end, tighter than a car or a rider on the road's edge takes it). Between a lane and its
successor, the junction's own internal lanes, chained end to start, draw the way across
(`crossing`); a map without them is crossed in a straight line.

Kinds: `car` — road lanes open to passenger cars; `bike` — bike lanes and road lanes open to
bicycles.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable

from carlaverse.messages import MapLane, MapReply
from carlaverse.traffic.polyline import length

U_TURN_RAD = math.radians(150.0)  # [rad] a turn through a junction sharper than this is a U-turn
JOIN_M = 0.3  # [m] a lane starting this close to where another ends continues it
MAX_CROSSING_LANES = 4  # internal lanes chained across one junction, at most


def usable(lane: MapLane, kind: str) -> bool:
    """May a road user of `kind` (car | bike) use `lane`?"""
    if len(lane.centerline) < 2:
        return False
    if kind == "car":
        return lane.kind == "road" and (not lane.allow or "passenger" in lane.allow)
    if lane.kind == "bike":
        return True
    return lane.kind == "road" and (not lane.allow or "bicycle" in lane.allow)


def _heading(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.atan2(b[1] - a[1], b[0] - a[0])


def reverses(a: MapLane, b: MapLane) -> bool:
    """Does going on from `a` into `b` turn back by more than `U_TURN_RAD`?"""
    out = _heading(a.centerline[-2], a.centerline[-1])
    into = _heading(b.centerline[0], b.centerline[1])
    return abs(math.remainder(into - out, 2 * math.pi)) > U_TURN_RAD


class LaneGraph:
    """The usable lanes of `reply` for `kind` and where each leads."""

    def __init__(self, reply: MapReply, kind: str) -> None:
        self.kind = kind
        self.lanes = {lane.id: lane for lane in reply.lanes if usable(lane, kind)}
        self.length = {lane_id: length(lane.centerline) for lane_id, lane in self.lanes.items()}
        self.next: dict[str, list[str]] = {
            lane_id: [
                s for s in dict.fromkeys(lane.successors)
                if s in self.lanes and not reverses(lane, self.lanes[s])
            ]
            for lane_id, lane in self.lanes.items()
        }  # fmt: skip
        self._starts: dict[tuple[int, int], list[MapLane]] = {}
        for lane in self.lanes.values():
            self._starts.setdefault(_cell(lane.centerline[0]), []).append(lane)
        self._crossings: dict[tuple[str, str], list[MapLane]] = {}

    def crossing(self, a: str, b: str) -> list[MapLane]:
        """The internal lanes from the end of `a` to the start of `b` ([] when none)."""
        key = (a, b)
        if key not in self._crossings:
            self._crossings[key] = self._chain(self.lanes[a], self.lanes[b])
        return self._crossings[key]

    def _chain(self, a: MapLane, b: MapLane) -> list[MapLane]:
        here = a.centerline[-1]
        chain: list[MapLane] = []
        for _ in range(MAX_CROSSING_LANES):
            if math.dist(here, b.centerline[0]) <= JOIN_M:
                return chain
            step = next(
                (lane for lane in self._starting_at(here)
                 if b.id in lane.successors and lane not in chain and lane is not b),
                None,
            )  # fmt: skip
            if step is None:
                break
            chain.append(step)
            here = step.centerline[-1]
        return chain if math.dist(here, b.centerline[0]) <= JOIN_M else []

    def _starting_at(self, point: tuple[float, float]) -> Iterable[MapLane]:
        cx, cy = _cell(point)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for lane in self._starts.get((cx + dx, cy + dy), []):
                    if math.dist(lane.centerline[0], point) <= JOIN_M:
                        yield lane

    def reachable(self, start: str) -> set[str]:
        seen, todo = {start}, [start]
        while todo:
            for after in self.next[todo.pop()]:
                if after not in seen:
                    seen.add(after)
                    todo.append(after)
        return seen

    def loop_core(self, start: str) -> set[str]:
        """The largest set of lanes reachable from `start` in which every lane reaches every
        other (a strongly connected component with a cycle); empty when there is none."""
        nodes = self.reachable(start)
        best: set[str] = set()
        for component in strongly_connected(nodes, self.next):
            cyclic = len(component) > 1 or any(n in self.next[n] for n in component)
            if cyclic and len(component) > len(best):
                best = component
        return best

    def shortest(self, source: str, targets: set[str], within: set[str] | None = None
                 ) -> list[str] | None:  # fmt: skip
        """The shortest way (by length) from `source` to any lane of `targets`, both ends
        included, through `within` (default: any lane); None when there is none."""
        queue: list[tuple[float, str]] = [(0.0, source)]
        came: dict[str, str | None] = {source: None}
        done: set[str] = set()
        while queue:
            dist, here = heapq.heappop(queue)
            if here in done:
                continue
            if here in targets and (here != source or source in targets):
                return _path(came, here)
            done.add(here)
            for after in self.next[here]:
                if after not in came and (within is None or after in within):
                    came[after] = here
                    heapq.heappush(queue, (dist + self.length[after], after))
        return None


def _path(came: dict[str, str | None], end: str) -> list[str]:
    path = [end]
    while (before := came[path[-1]]) is not None:
        path.append(before)
    return path[::-1]


def _cell(point: tuple[float, float]) -> tuple[int, int]:
    return math.floor(point[0]), math.floor(point[1])


def strongly_connected(nodes: set[str], edges: dict[str, list[str]]) -> list[set[str]]:
    """The strongly connected components of the graph on `nodes` (Kosaraju, iterative)."""
    order: list[str] = []
    seen: set[str] = set()
    for root in sorted(nodes):
        if root in seen:
            continue
        seen.add(root)
        stack = [(root, iter(edges[root]))]
        while stack:
            node, children = stack[-1]
            child = next((c for c in children if c in nodes and c not in seen), None)
            if child is None:
                order.append(node)
                stack.pop()
            else:
                seen.add(child)
                stack.append((child, iter(edges[child])))
    backward: dict[str, list[str]] = {n: [] for n in nodes}
    for n in nodes:
        for c in edges[n]:
            if c in nodes:
                backward[c].append(n)
    components, assigned = [], set()
    for root in reversed(order):
        if root in assigned:
            continue
        component, todo = {root}, [root]
        assigned.add(root)
        while todo:
            for before in backward[todo.pop()]:
                if before not in assigned:
                    assigned.add(before)
                    component.add(before)
                    todo.append(before)
        components.append(component)
    return components
