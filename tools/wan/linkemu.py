"""Put an emulated WAN link in front of a Zenoh router, by hand (no root, no netem).

    python tools/wan/linkemu.py --listen 127.0.0.1:17447 --target 127.0.0.1:7447 \\
        --delay-ms 30 --jitter-ms 10

Then point the other site's router at `tcp/127.0.0.1:17447` instead of `...:7447`. Type
`cut`, `restore`, `stall SECONDS`, `reset`, `delay MS [JITTER_MS]` or `stats` on stdin to
change the link while it runs; Ctrl-D or Ctrl-C ends it. The library behind it is
`carlaverse.testing.linkemu` (what the WAN tests use); see its docstring for what each
impairment means on a TCP link.
"""

from __future__ import annotations

import argparse
import sys

from carlaverse.testing.linkemu import LinkEmulator, LinkProfile


def _address(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit():
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, got {text!r}")
    return host, int(port)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--listen", type=_address, required=True, metavar="HOST:PORT")
    parser.add_argument("--target", type=_address, required=True, metavar="HOST:PORT")
    parser.add_argument("--delay-ms", type=float, default=30.0, help="one-way delay [ms]")
    parser.add_argument("--jitter-ms", type=float, default=0.0, help="± jitter [ms]")
    parser.add_argument(
        "--loss", type=float, default=0.0, help="fraction of segments lost (retransmitted)"
    )
    parser.add_argument("--seed", type=int, default=0)
    return parser.parse_args(argv)


def command(emu: LinkEmulator, line: str) -> str:
    """Apply one stdin command; returns what to print."""
    word, *rest = line.split() or [""]
    if word in ("cut", "restore", "reset"):
        getattr(emu, word)()
    elif word == "stall" and rest:
        emu.stall(float(rest[0]))
    elif word == "delay" and rest:
        jitter = float(rest[1]) if len(rest) > 1 else 0.0
        emu.set_profile(LinkProfile(float(rest[0]) / 1e3, jitter / 1e3))
    elif word != "stats":
        return "commands: cut | restore | stall S | reset | delay MS [JITTER_MS] | stats"
    return f"{word or 'stats'}: {dict(emu.counts)}, held {emu.held}"


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        profile = LinkProfile(args.delay_ms / 1e3, args.jitter_ms / 1e3, args.loss)
        emu = LinkEmulator(args.listen, args.target, profile, seed=args.seed).start()
    except (ValueError, RuntimeError, OSError) as exc:
        print(f"linkemu: {exc}", file=sys.stderr)
        return 2
    print(f"relaying {emu.address} -> {args.target} ({profile})", file=sys.stderr)
    try:
        for line in sys.stdin:
            try:
                print(command(emu, line), file=sys.stderr)
            except ValueError as exc:
                print(f"linkemu: {exc}", file=sys.stderr)
    except KeyboardInterrupt:
        pass
    finally:
        emu.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
