"""Benchmark: the renderer's frame time with 200 NPCs and 16 egos, offscreen, per quality.

    python tools/bench/bench_render.py [--frames 40] [--quality auto] [--baseline flat] [--write]
    python tools/bench/bench_render.py --drive-timing [--duration 20] [--write]

For each rig — one 1920×1080 display (simple) and three 1920×1080 displays (physical, one
span buffer of 5760×1080) — and each weather (a day with light fog; a rainy night with every
vehicle's low beams on), the synthetic crossing map is built once per quality, then every
frame moves all 216 actors (brake lamps and blinkers on some) and draws them from an ego's
head. A frame is timed from the scene update to the pixels in RAM (`Renderer.draw` + reading
every output back), as `carlaverse render` and a pixel test need them; a window would skip the
read-back. The GL renderer string is the one the driver reports at run time. Beside the wall
time each frame's CPU time is taken (the process's, all threads: llvmpipe rasterises in
threads of its own): on a machine whose cores other work shares, waiting for a core inflates
the wall time of the quality that needs more of them, the CPU time much less.

`--baseline` names a second quality drawn in the same run, frame for frame interleaved with
the first (which of the two draws first alternates), so both see the same machine and load:
`flat` is the renderer before shading, shadows, textures and night lights (issue 42), and the
ratio column is the cost of the quality asked for against it. The `cpu` preset's budget is
1.5× `flat` at both sizes.

`--drive-timing` measures what the view costs the drive node: `carlaverse join drive
--backend sim` in the town scenario, once alone and once with `--view --offscreen` (the render
process at its rig's rate), reporting the 1 kHz loop's period error from the loop itself.

A measurement, not a test.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_drive_timing import run as run_drive
from benchdoc import RunInfo, command_line, write_section

from carlaverse import messages as m
from carlaverse.recording.synthetic import light_state, synthetic_map
from carlaverse.render.frame import KIND_EXTENTS, ActorDraw, SceneFrame
from carlaverse.render.quality import PRESETS
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import PhysicalRig, RenderConfig, Resolution, SimpleRig

NPCS, EGOS = 200, 16
TARGET_FPS = 60  # [1/s] the first-person view's target, on a GPU
FULL_HD = Resolution(width=1920, height=1080)
RIGS = {
    "1 × 1920×1080 (simple, 90°)": SimpleRig(resolution=FULL_HD, fov_deg=90),
    "3 × 1920×1080 (physical, span)": PhysicalRig(
        displays=3, resolution=FULL_HD, display_width_m=0.615, bezel_m=0.012, distance_m=0.7
    ),
}
KINDS = ("car", "car", "car", "van", "truck", "bus", "motorcycle", "bicycle", "pedestrian")
WEATHERS = {
    "day, light fog": m.Weather(0, 0.0, sun_altitude_deg=35, cloudiness=0.3, fog_density=0.1),
    "night, rain": m.Weather(0, 0.0, sun_altitude_deg=-20, cloudiness=0.9, precipitation=0.8,
                             wetness=0.9, fog_density=0.1),
}  # fmt: skip
BUDGET = 1.5  # the cpu preset's frame time against flat's


def actors_at(t: float, beams: bool = False) -> tuple[ActorDraw, ...]:
    """NPCs driving both roads of the crossing and egos circling it, at time t [s]."""
    out = []
    for i in range(NPCS):
        kind = KINDS[i % len(KINDS)]
        e = KIND_EXTENTS[kind]
        s = (i * 7.0 + 8.0 * t) % 190.0 - 95.0  # [m] along the road
        lane = -1.75 if i % 2 else 1.75
        x, y, yaw = (s, lane, 0.0) if i % 4 < 2 else (lane, s, math.pi / 2)
        bits = m.LIGHT_BRAKE if i % 3 == 0 else (m.LIGHT_LEFT_BLINKER if i % 5 == 0 else 0)
        bits |= m.LIGHT_LOW_BEAM if beams else 0
        out.append(ActorDraw(f"npc-{i}", kind, x, y, 0.0, yaw, e.length, e.width, e.height,
                             lights=bits))  # fmt: skip
    for i in range(EGOS):
        r, a = 20.0 + 3.0 * i, 0.3 * t + i
        e = KIND_EXTENTS["car"]
        out.append(ActorDraw(f"ego-{i}", "car", r * math.cos(a), r * math.sin(a), 0.0,
                             a + math.pi / 2, e.length, e.width, e.height, ego=True))  # fmt: skip
    return tuple(out)


def bench(rig, weather: m.Weather, qualities: list[str], frames: int) -> list[dict]:
    """Frame times per quality, the qualities' frames interleaved in one run."""
    renderers = [Renderer(RenderConfig(output="offscreen", camera=rig, quality=q),
                          synthetic_map()) for q in qualities]  # fmt: skip
    times: list[list[float]] = [[] for _ in qualities]
    cpu: list[list[float]] = [[] for _ in qualities]
    beams = weather.sun_altitude_deg < 0
    try:
        for k in range(frames + 3):  # the first frames compile shaders and upload meshes
            t = k / 60
            frame = SceneFrame(t, actors_at(t, beams), light_state(k, t), weather)
            pairs = list(zip(renderers, times, cpu, strict=True))
            # which draws first changes each frame: the one after another's pixels left the
            # caches pays for it (measured: ~8 % of a 1080p frame on llvmpipe)
            for renderer, timed, used in pairs if k % 2 == 0 else pairs[::-1]:
                start, start_cpu = time.perf_counter(), time.process_time()
                renderer.draw(frame, follow="ego-0")
                renderer.images()
                if k >= 3:
                    timed.append(time.perf_counter() - start)
                    used.append(time.process_time() - start_cpu)
        out = []
        for renderer, timed, used in zip(renderers, times, cpu, strict=True):
            ms = np.array(timed) * 1e3
            size = "+".join(f"{w}×{h}" for w, h in renderer.layout.outputs)
            out.append({"quality": renderer.graphics.preset.name, "size": size,
                        "p50": float(np.percentile(ms, 50)), "p99": float(np.percentile(ms, 99)),
                        "cpu_p50": float(np.percentile(np.array(used) * 1e3, 50)),
                        "gl": renderer.gl_renderer, "frames": len(timed)})  # fmt: skip
        return out
    finally:
        for renderer in renderers:
            renderer.close()


VIEW_RIG = """output: offscreen
camera: {mode: simple, resolution: {width: %d, height: %d}, fov_deg: 90, head: {z: 1.2}}
max_fps: %d
"""
VIEW_SIZES = ((640, 360), (1280, 720))
VIEW_SCENARIO = "town"


def drive_timing(duration: float) -> list[str]:
    """Rows: the drive loop's period error without and with its view running."""
    lines = ["| drive node | ticks | period error p50 [ms] | p99 [ms] | max [ms] | "
             "view frames | view fps | view frame p50 / p99 [ms] |",
             "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        runs: list[tuple[str, list[str]]] = [("loop alone", [])]
        for w, h in VIEW_SIZES:
            rig = Path(tmp) / f"rig-{w}.yaml"
            rig.write_text(VIEW_RIG % (w, h, TARGET_FPS))
            flags = ["--view", "--offscreen", "--render-config", str(rig)]
            runs.append((f"with its view, {w}×{h} offscreen", flags))
        for label, flags in runs:
            r = run_drive(duration, 0, flags, scenario=VIEW_SCENARIO)
            lines.append(_timing_row(label, r))
            print(lines[-1], flush=True)
    return lines


def _timing_row(label: str, r: dict) -> str:
    view = r.get("view")
    shown = "– | – | –"
    if view:
        shown = (f"{view['frames']} | {view['fps']:.1f} | "
                 f"{view['frame_ms_p50']:.1f} / {view['frame_ms_p99']:.1f}")  # fmt: skip
    error = f"{r['period_error_p50_ms']:.4f} | {r['period_error_p99_ms']:.4f}"
    return f"| {label} | {r['ticks']} | {error} | {r['period_error_max_ms']:.3f} | {shown} |"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=40, help="timed frames per rig")
    parser.add_argument("--quality", default="auto", choices=["auto", *PRESETS],
                        help="the render quality measured")  # fmt: skip
    parser.add_argument("--baseline", default="flat", choices=["", *PRESETS],
                        help="a quality drawn in the same run to compare with ('' for none)",
                        )  # fmt: skip
    parser.add_argument("--drive-timing", action="store_true",
                        help="the drive loop's period error with and without its view")  # fmt: skip
    parser.add_argument("--duration", type=float, default=20.0, help="[s] per drive run")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md section")
    args = parser.parse_args(argv)
    run = RunInfo.start()
    if args.drive_timing:
        lines = [*drive_timing(args.duration), "", drive_notes()]
        if args.write:
            write_section(
                "Drive loop timing with its view", "\n".join(lines), command_line(argv), run
            )
        return 0
    qualities = [args.quality] + ([args.baseline] if args.baseline else [])
    lines, gl, over = render_rows(qualities, args.frames)
    lines += ["", f"GL renderer (as the driver reports it): `{gl}`. {NPCS} NPCs and {EGOS} "
              "egos, synthetic crossing map; by night every vehicle's low beams are on.", "",
              notes(gl, args.baseline)]  # fmt: skip
    if over is not None:
        lines += [
            "",
            f"`cpu` over its {BUDGET}× budget in this run: {'; '.join(over)}."
            if over
            else f"`cpu` within its {BUDGET}× budget in every case of this run.",
        ]
    if args.write:
        write_section("Renderer", "\n".join(lines), command_line(argv), run)
    return 0


def render_rows(qualities: list[str], frames: int) -> tuple[list[str], str, list[str] | None]:
    """The table's rows (one per rig, weather and quality), the GL renderer, and the cases
    where the `cpu` preset costs more than its budget against a `flat` baseline (None when
    the run did not compare those two)."""
    lines = ["| rig | weather | quality | output | frames | frame p50 [ms] | frame p99 [ms] | "
             "fps at p50 | p50 / baseline | CPU time p50 [ms] | CPU p50 / baseline |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    gl, over, compared = "", [], False
    for name, rig in RIGS.items():
        for weather_name, weather in WEATHERS.items():
            rows = bench(rig, weather, qualities, frames)
            base = rows[-1]["p50"] if len(rows) > 1 else float("nan")
            base_cpu = rows[-1]["cpu_p50"] if len(rows) > 1 else float("nan")
            for r in rows:
                gl = r["gl"]
                ratio = f"{r['p50'] / base:.2f}" if len(rows) > 1 else "–"
                cpu_ratio = f"{r['cpu_p50'] / base_cpu:.2f}" if len(rows) > 1 else "–"
                if r["quality"] == "cpu" and rows[-1]["quality"] == "flat":
                    compared = True
                    if r["p50"] > BUDGET * base:
                        over.append(f"{name}, {weather_name} ({ratio}×)")
                lines.append(f"| {name} | {weather_name} | {r['quality']} | {r['size']} | "
                             f"{r['frames']} | {r['p50']:.1f} | {r['p99']:.1f} | "
                             f"{1e3 / r['p50']:.1f} | {ratio} | {r['cpu_p50']:.1f} | "
                             f"{cpu_ratio} |")  # fmt: skip
                print(lines[-1], flush=True)
    return lines, gl, over if compared else None


def notes(gl_renderer: str, baseline: str) -> str:
    """What the frame times mean on the GL renderer this run had."""
    text = (
        "A frame is the scene update, the draw and reading every output's pixels back to RAM; "
        "its CPU time is the process's, all threads (llvmpipe's too), less inflated than the "
        "wall time by other work on the machine. "
    )
    if baseline:
        text += (f"Each quality's frames alternate with the baseline's ({baseline}) in one run; "
                 f"the `cpu` preset's budget is {BUDGET}× `flat`'s p50. ")  # fmt: skip
    if "llvmpipe" in gl_renderer or "softpipe" in gl_renderer:
        return text + (
            "This GL renderer rasterises on the CPU, so these figures are the CPU's and the "
            f"machine's load; the {TARGET_FPS} fps target is for a GPU (quality `full`) and is "
            "still to be measured on one."
        )
    return text + f"Target: {TARGET_FPS} fps on this GPU."


def drive_notes() -> str:
    from carlaverse.traffic.scenario import load_scenario

    traffic = load_scenario(VIEW_SCENARIO).spec.traffic
    return (
        "The view runs in its own process (own pose from the loop's shared memory, everyone "
        f"else through its own observer connection; the {VIEW_SCENARIO} scenario with its "
        f"generated buildings and parks, {traffic.vehicles.count} cars and "
        f"{traffic.pedestrians.count} pedestrians), capped at {TARGET_FPS} fps. Its frame time "
        "is the world update, the draw and reading the pixels back (an offscreen view reads "
        "every frame back, as its fps counts) on the machine's GL renderer (see the Renderer "
        "section), which shares the cores with the loop; the "
        "loop's own process is not touched."
    )


if __name__ == "__main__":
    raise SystemExit(main())
