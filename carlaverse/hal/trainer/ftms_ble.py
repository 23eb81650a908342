"""`backend: ftms` — a Bluetooth FTMS smart trainer through bleak.

bleak is asyncio; the control loop is not. The link runs its own event loop on a daemon
thread: it scans for a device advertising the Fitness Machine service (0x1826) — or the one
named by `address` / `name` — connects, subscribes to Indoor Bike Data (0x2AD2) and to the
control point's indications (0x2AD9), and reconnects with a growing back-off whenever the
link drops. Control-point writes are handed to that loop and never waited for.

    trainer:
      backend: ftms
      options: {name: "KICKR", scan_timeout_s: 10}

Needs `pip install 'carlaverse[bike]'`; tested only with `pytest --hardware` (a real trainer).
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from typing import Annotated, Any

import msgspec
from bleak import BleakClient, BleakScanner
from bleak.exc import BleakError

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.trainer import ftms_codec as codec
from carlaverse.hal.trainer.ftms import FtmsTrainer, LinkHandler

log = logging.getLogger(__name__)
Positive = Annotated[float, msgspec.Meta(gt=0)]


class BleFtmsOptions(StrictStruct):
    address: str = ""  # MAC (Linux) or UUID (macOS); empty: the first FTMS device found
    name: str = ""  # or a substring of its advertised name
    scan_timeout_s: Positive = 10.0
    reconnect_min_s: Positive = 0.5  # back-off after a loss, doubling up to the max
    reconnect_max_s: Positive = 8.0


class BleLink:
    """FTMS bytes over BLE; see the module docstring."""

    def __init__(self, options: BleFtmsOptions) -> None:
        self.options = options
        self.handler: LinkHandler | None = None
        self.loop = asyncio.new_event_loop()
        self.client: BleakClient | None = None
        self.lost = asyncio.Event()
        self.stopping = False
        self.thread = threading.Thread(target=self.loop.run_forever, name="ftms-ble", daemon=True)

    def start(self, handler: LinkHandler) -> None:
        self.handler = handler
        self.thread.start()
        asyncio.run_coroutine_threadsafe(self._keep_connected(), self.loop)

    async def _keep_connected(self) -> None:
        backoff = self.options.reconnect_min_s
        while not self.stopping:
            try:
                await self._session()
                backoff = self.options.reconnect_min_s
            except (TimeoutError, BleakError, OSError) as exc:
                log.warning("FTMS trainer: %s; retrying in %.1f s", exc, backoff)
            if self.handler is not None and self.client is not None:
                self.handler.on_connected(False)
            self.client = None
            await asyncio.sleep(backoff)
            backoff = min(backoff * 2, self.options.reconnect_max_s)

    async def _session(self) -> None:
        device = await self._find()
        self.lost.clear()
        async with BleakClient(device, disconnected_callback=lambda _c: self._on_lost()) as c:
            self.client = c
            await c.start_notify(codec.INDOOR_BIKE_DATA, self._bike_data)
            await c.start_notify(codec.CONTROL_POINT, self._response)
            assert self.handler is not None
            self.handler.on_connected(True)
            await self.lost.wait()

    async def _find(self) -> Any:
        o = self.options
        if o.address:
            device = await BleakScanner.find_device_by_address(o.address, o.scan_timeout_s)
        else:
            device = await BleakScanner.find_device_by_filter(
                lambda d, adv: (
                    codec.FTMS_SERVICE in adv.service_uuids
                    and (not o.name or o.name.lower() in (d.name or "").lower())
                ),
                o.scan_timeout_s,
                service_uuids=[codec.FTMS_SERVICE],
            )
        if device is None:
            raise BleakError(f"no FTMS trainer found in {o.scan_timeout_s:.0f} s of scanning")
        return device

    def _on_lost(self) -> None:
        self.loop.call_soon_threadsafe(self.lost.set)

    def _bike_data(self, _char: Any, data: bytearray) -> None:
        if self.handler is not None:
            self.handler.on_bike_data(bytes(data))

    def _response(self, _char: Any, data: bytearray) -> None:
        if self.handler is not None:
            self.handler.on_response(bytes(data))

    def write_control(self, data: bytes) -> None:
        asyncio.run_coroutine_threadsafe(self._write(data), self.loop)

    async def _write(self, data: bytes) -> None:
        client = self.client
        if client is None or not client.is_connected:
            return
        try:
            await client.write_gatt_char(codec.CONTROL_POINT, data, response=True)
        except (BleakError, OSError) as exc:
            log.warning("FTMS control-point write failed: %s", exc)

    def poll(self, now: float) -> None:
        """Notifications arrive on the link's own thread."""

    def close(self) -> None:
        self.stopping = True
        self._on_lost()
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(timeout=5)


class BleFtmsTrainer(FtmsTrainer):
    Options = BleFtmsOptions

    def __init__(self, options: BleFtmsOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, BleLink(options), clock=clock)
