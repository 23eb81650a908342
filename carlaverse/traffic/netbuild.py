"""Turning a scenario's map source into a SUMO network, built once and cached.

Generated towns go through `netgenerate`; plain XML, OpenDRIVE and OSM through `netconvert`
(OSM polygons through `polyconvert`). Results are cached under `$CARLAVERSE_CACHE` (default
`~/.cache/carlaverse`) keyed by a hash of the tool version, the options and the content of
every input file, so editing a map rebuilds it and nothing else does.
"""

from __future__ import annotations

import hashlib
import logging
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from carlaverse.traffic.scenario import GeneratedMap, GridTown, MapSource, Scenario, SpiderTown
from carlaverse.traffic.sumo_tools import run_tool, sumo_homes, tool_version

log = logging.getLogger(__name__)

# Options every converted network gets: walking areas for pedestrians, no U-turns in the
# middle of town (they confuse human drivers), U-turns at dead ends so traffic can leave them.
COMMON_NETCONVERT = ["--walkingareas", "--no-turnarounds", "true"]
COMMON_NETCONVERT += ["--no-turnarounds.except-deadend", "true"]
OSM_OPTIONS = ["--osm.sidewalks", "--osm.crossings", "--geometry.remove", "--junctions.join"]
OSM_OPTIONS += ["--tls.guess-signals", "--tls.discard-simple", "--tls.join"]
OSM_OPTIONS += ["--output.original-names"]
# OpenDRIVE lane types -> SUMO permissions (sidewalk lanes for pedestrians only, ...).
OPENDRIVE_TYPEMAPS = ("opendriveNetconvert.typ.xml", "opendriveNetconvertPedestrians.typ.xml")


@dataclass(frozen=True, slots=True)
class BuiltMap:
    net: Path  # the SUMO .net.xml
    polygons: Path | None  # optional .poly.xml with vegetation, water and buildings


def cache_root(override: Path | None = None) -> Path:
    """Where built networks are kept: the override, $CARLAVERSE_CACHE or ~/.cache/carlaverse."""
    if override is not None:
        return override
    env = os.environ.get("CARLAVERSE_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "carlaverse"


def build_map(scenario: Scenario, cache_dir: Path | None = None) -> BuiltMap:
    """The network (and polygons) of a scenario, building it if the cache lacks it."""
    source = scenario.spec.map
    polygons = scenario.resolve(source.polygons) if source.polygons else None
    if source.net:
        return BuiltMap(scenario.resolve(source.net), polygons)
    root = cache_root(cache_dir) / "nets"
    if source.generate is not None:
        args = _generate_args(source.generate)
        net = _cached(root, "netgenerate", scenario.spec.name, args, [], source.netconvert_options)
        return BuiltMap(net, polygons)
    args, inputs = _convert_args(scenario, source)
    net = _cached(root, "netconvert", scenario.spec.name, args, inputs, source.netconvert_options)
    if source.osm and polygons is None:
        polygons = _osm_polygons(root, scenario.resolve(source.osm), net)
    return BuiltMap(net, polygons)


def _generate_args(gen: GeneratedMap) -> list[str]:
    args = ["--seed", "1", "--default.lanenumber", str(gen.lanes)]
    args += ["--default.speed", f"{gen.speed_mps:g}", *COMMON_NETCONVERT]
    town = _grid_args(gen.grid) if gen.kind == "grid" else _spider_args(gen.spider)
    return args + town + _street_args(gen)


def _grid_args(g: GridTown) -> list[str]:
    args = ["--grid", "--grid.x-number", str(g.junctions)]
    args += ["--grid.y-number", str(g.junctions_y or g.junctions)]
    args += ["--grid.length", f"{g.length_m:g}"]
    return [*args, "--grid.attach-length", f"{g.attach_length_m:g}"]


def _spider_args(s: SpiderTown) -> list[str]:
    args = ["--spider", "--spider.arm-number", str(s.arms)]
    args += ["--spider.circle-number", str(s.circles), "--spider.space-radius", f"{s.radius_m:g}"]
    return args + (["--spider.omit-center"] if s.omit_center else [])


def _street_args(gen: GeneratedMap) -> list[str]:
    """Signals, sidewalks, crossings, bike lanes and oncoming pairs, guessed by netgenerate."""
    args = []
    if gen.traffic_lights:
        # A low guessing threshold signalises every real junction but not the dead ends.
        args += ["--tls.guess", "--tls.guess.threshold", "20"]
    if gen.sidewalks:
        args += ["--sidewalks.guess", "--default.sidewalk-width", f"{gen.sidewalk_width_m:g}"]
    if gen.sidewalks and gen.crossings:
        args.append("--crossings.guess")
    if gen.bike_lanes:
        args += ["--bikelanes.guess", "--default.bikelane-width", f"{gen.bike_lane_width_m:g}"]
    if gen.overtaking:
        args.append("--opposites.guess")
    return args


def _convert_args(scenario: Scenario, source: MapSource) -> tuple[list[str], list[Path]]:
    args = list(COMMON_NETCONVERT)
    if source.plain is not None:
        inputs = [scenario.resolve(source.plain.nodes), scenario.resolve(source.plain.edges)]
        args += ["-n", str(inputs[0]), "-e", str(inputs[1]), "--crossings.guess"]
        if source.plain.connections:
            inputs.append(scenario.resolve(source.plain.connections))
            args += ["-x", str(inputs[2])]
    elif source.opendrive:
        inputs = [scenario.resolve(source.opendrive)]
        args += ["--opendrive-files", str(inputs[0]), "--opendrive.import-all-lanes"]
        args.append("--output.original-names")
        typemaps = [p for name in OPENDRIVE_TYPEMAPS if (p := _typemap(name)) is not None]
        if typemaps:
            args += ["--type-files", ",".join(str(p) for p in typemaps)]
            inputs += typemaps
    else:
        inputs = [scenario.resolve(str(source.osm))]
        args += ["--osm-files", str(inputs[0]), *OSM_OPTIONS]
    if source.guess_sidewalks:
        args += ["--sidewalks.guess", "--crossings.guess"]
    return args, inputs


def _typemap(name: str) -> Path | None:
    """A type map shipped in SUMO's data directory, or None when this install lacks it."""
    for home in sumo_homes():
        if (home / "data" / "typemap" / name).is_file():
            return home / "data" / "typemap" / name
    log.warning("SUMO type map %s not found; lane permissions fall back to netconvert's", name)
    return None


def _cached(
    root: Path, tool: str, stem: str, args: list[str], inputs: list[Path], extra: list[str]
) -> Path:
    """Run `tool args extra -o OUT` unless OUT for this exact input is already cached."""
    full = [*args, *extra]
    key = _digest(tool_version(tool), full, inputs)
    out = root / f"{_safe(stem)}-{key[:16]}.net.xml"
    if out.is_file():
        log.info("map %s: cached %s", stem, out)
        return out
    _write_atomically(out, lambda tmp: run_tool(tool, [*full, "-o", str(tmp)]))
    log.info("map %s: built %s", stem, out)
    return out


def _osm_polygons(root: Path, osm: Path, net: Path) -> Path | None:
    typemap = _typemap("osmPolyconvert.typ.xml")
    if typemap is None:
        return None
    key = _digest(tool_version("polyconvert"), [str(typemap)], [osm, net])
    out = root / f"{_safe(osm.stem)}-{key[:16]}.poly.xml"
    if not out.is_file():
        args = ["--osm-files", str(osm), "--net-file", str(net), "--type-file", str(typemap)]
        _write_atomically(out, lambda tmp: run_tool("polyconvert", [*args, "-o", str(tmp)]))
    return out


def _write_atomically(out: Path, produce: Callable[[Path], object]) -> None:
    """Build into a temporary file beside `out`, then rename: readers never see half a net."""
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=out.stem, suffix=".tmp.xml", dir=out.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        produce(tmp)
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)


def _digest(version: str, args: list[str], inputs: list[Path]) -> str:
    h = hashlib.sha256(version.encode())
    # Input paths differ between machines; their content is what matters.
    names = {str(p) for p in inputs}
    for arg in args:
        h.update(b"\0" + (b"<input>" if arg in names else arg.encode()))
    for path in inputs:
        h.update(b"\0" + path.read_bytes())
    return h.hexdigest()


def _safe(stem: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in stem) or "map"
