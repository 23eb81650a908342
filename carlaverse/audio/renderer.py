"""The spatial audio renderer: emitters in, one block of multi-channel audio out.

Per block (all emitters at once, as numpy arrays):
 1. drive values glide, positions dead-reckon to the block's end;
 2. the travel time τ of each emitter's sound (`propagation.travel_time_s`), from where it
    left the source; 1/r spreading and ISO 9613-1 air absorption (`air`) for that distance;
 3. each source renders a block (`sources`), goes through its delay line read at t − τ(t),
    ramped over the block (the Doppler shift);
 4. overlap-save spectra of every emitter (one real FFT over all of them) go through their
    weights (gain × absorption × HRTF, or × speaker gains) into the output channels, twice:
    with the block's old weights (kept from the previous block) and its new ones; back to
    time and crossfaded over the block, so a change of direction, level or filter never
    clicks;
 5. a master limiter keeps peaks under full scale.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from carlaverse.audio.air import (
    AirAbsorption,
    one_pole_response,
    speed_of_sound_mps,
    unit_delays,
)
from carlaverse.audio.blockfft import OverlapSave
from carlaverse.audio.blockfft import fft_size as _fft_size
from carlaverse.audio.config import AudioConfig
from carlaverse.audio.hrtf import TAPS, HrirSet
from carlaverse.audio.limiter import Limiter
from carlaverse.audio.listener import ListenerPose
from carlaverse.audio.propagation import MIN_DISTANCE_M, DelayLines, travel_time_s
from carlaverse.audio.scene import FADING, SCENE, EmitterLike, EmitterSlots
from carlaverse.audio.sources import Drive, SourceBank

POLE_TAIL = 256  # [samples] FFT history kept for the absorption pole's decay (≤ 0.97^256)


# Each spatialiser's own weights, handed back to it only: an array (Binaural), a dataclass of
# arrays (Panned). Any, so each implementation's methods may name their own type.
Weights = Any


class Spatialiser(Protocol):
    """binaural.Binaural or panning.Panned: how emitters' spectra reach the output channels.
    Weights are per emitter (an array or a dataclass of arrays, first axis the emitter)."""

    channels: int

    def weights(self, response: np.ndarray, directions: np.ndarray,
                diffuse: np.ndarray) -> Weights: ...  # fmt: skip

    def silent(self, n: int, bins: int) -> Weights: ...

    def take(self, weights: Weights, sel: np.ndarray | slice) -> Weights: ...

    def mix(self, spectra: np.ndarray, weights: Weights) -> np.ndarray: ...

    def finish(self, block: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class Heard:
    """Per live emitter this block: the spatialiser's weights for it."""

    slots: np.ndarray
    weights: object


def fft_size(block: int) -> int:
    """The renderer's FFT: a block, an HRIR and the absorption pole's tail."""
    return _fft_size(block, TAPS + POLE_TAIL)


class Renderer:
    """Renders blocks for one listener; `spatialiser` is binaural.Binaural or panning.Panned."""

    def __init__(self, config: AudioConfig, spatialiser: Spatialiser) -> None:
        self.config = config
        self.spatial = spatialiser
        self.channels = spatialiser.channels
        self.block = config.block_size
        self.rate = config.sample_rate_hz
        self.c_mps = speed_of_sound_mps(config.air)
        self.n_fft = fft_size(self.block)
        capacity = config.max_emitters
        self.slots = EmitterSlots(capacity)
        self.sources = SourceBank(capacity, self.rate, self.block, config.seed)
        self.delays = DelayLines(capacity, config.max_distance_m / self.c_mps + 0.05, self.rate,
                                 self.block)  # fmt: skip
        self.air = AirAbsorption(config.air, self.rate, config.max_distance_m)
        self._delays = unit_delays(self.n_fft)
        self.convolver = OverlapSave(capacity, self.block, self.n_fft)
        self.tau_s = np.zeros(capacity)
        self.bins = self.convolver.bins
        self.weights = spatialiser.silent(capacity, self.bins)
        self.listener = ListenerPose()
        self.limiter = Limiter(self.rate, self.block)
        self.t = 0.0  # [s] render time of the next block's first sample
        self.blocks = 0
        n = np.arange(self.block) + 1.0
        self._fade_in = (0.5 - 0.5 * np.cos(np.pi * n / self.block)).astype(np.float32)
        self._glide = min(1.0, self.block / self.rate / config.glide_s)

    def hear(self, emitters: Iterable[EmitterLike], t: float, owner: str = SCENE) -> None:
        """Take an AudioScene's emitters (or this node's own, owner LOCAL) valid at render
        time `t`; the owner's emitters missing from it fade out."""
        self.slots.apply(emitters, t, owner)

    def place(self, listener: ListenerPose) -> None:
        """Where the ears are from now on (dead-reckoned with its velocity until replaced)."""
        self.listener = listener

    def render_block(self) -> np.ndarray:
        """The next block (block × channels, float32, within ±1)."""
        t_end = self.t + self.block / self.rate
        self.slots.expire(self.t, self.config.stale_after_s)
        self._start_fresh()
        live = self.slots.live()
        out = np.zeros((self.channels, self.block), dtype=np.float32)
        if live.size:
            out = self._render_live(live, t_end)
        out = self.spatial.finish(out)  # the LFE's filter runs on silence too: its tail
        self.t = t_end
        self.blocks += 1
        return self.limiter.process(out.T)

    def _start_fresh(self) -> None:
        fresh = self.slots.take_fresh()
        if fresh.size == 0:
            return
        self.sources.reset(fresh)
        self.delays.clear(fresh)
        self.convolver.clear(fresh)
        # Fades in from silence over its first block.
        _assign(self.weights, fresh, self.spatial.silent(fresh.size, self.bins))
        relative, velocity = self._geometry(fresh, self.t)
        self.tau_s[fresh] = travel_time_s(relative, velocity, self.c_mps)

    def _geometry(self, slots: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        return self.slots.positions_at(slots, t) - self.listener.at(t), self.slots.velocity[slots]

    def _render_live(self, live: np.ndarray, t_end: float) -> np.ndarray:
        before, after = self.slots.glide(live, self._glide)
        drive = Drive(before[:, 0], after[:, 0], before[:, 1], after[:, 1])
        signal = self.sources.render(live, self.slots.kind[live], drive)
        relative, velocity = self._geometry(live, t_end)
        tau = travel_time_s(relative, velocity, self.c_mps)
        delayed = self.delays.process(live, signal, self.tau_s[live], tau)
        self.tau_s[live] = tau
        heard = self._heard(live, relative - velocity * tau[:, None], tau)
        spectra = self.convolver.spectra(live, delayed)
        old = self.spatial.take(self.weights, _rows(live))
        mixed = np.stack([self.spatial.mix(spectra, old), self.spatial.mix(spectra, heard.weights)])
        old, new = self.convolver.blocks(mixed)
        self._keep(heard)
        return old + (new - old) * self._fade_in[None, :]

    def _heard(self, live: np.ndarray, emitted_from: np.ndarray, tau: np.ndarray) -> Heard:
        """Gain, absorption and direction of each emitter's sound as it reaches the ears."""
        distance = np.maximum(tau * self.c_mps, 1e-6)
        amplitude = 10.0 ** ((self.slots.level_db[live] - self.config.full_scale_db_spl) / 20.0)
        gain = amplitude / np.maximum(distance, MIN_DISTANCE_M)
        gain[(self.slots.state[live] == FADING) | (distance > self.config.max_distance_m)] = 0.0
        flat, pole = self.air.at(distance)
        response = one_pole_response(pole, self._delays, gain * flat)
        head = (emitted_from / distance[:, None]) @ self.listener.rotation  # world → head
        extent = self.slots.extent_m[live]
        diffuse = np.where(extent > 0.0, extent / (extent + distance), 0.0)
        return Heard(live, self.spatial.weights(response, head, diffuse))

    def _keep(self, heard: Heard) -> None:
        """This block's parameters become the next block's old ones; faded slots free."""
        _assign(self.weights, _rows(heard.slots), heard.weights)
        faded = heard.slots[self.slots.state[heard.slots] == FADING]
        if faded.size:
            self.slots.release(faded)


def _rows(slots: np.ndarray) -> np.ndarray | slice:
    """Sorted slots as a slice when they are consecutive (the usual case: slots are taken
    from the lowest free), so per-slot state is read as a view and written without a
    gather; else the slots themselves."""
    if slots.size and slots[-1] - slots[0] + 1 == slots.size:
        return slice(int(slots[0]), int(slots[-1]) + 1)
    return slots


def _assign(state: object, slots: np.ndarray | slice, new: object) -> None:
    """Store per-emitter spatialiser state (an array, or a dataclass of arrays) at slots."""
    if isinstance(state, np.ndarray):
        state[slots] = new
        return
    for name in state.__dataclass_fields__:  # type: ignore[attr-defined]
        getattr(state, name)[slots] = getattr(new, name)


def build_renderer(config: AudioConfig, hrirs: HrirSet | None = None) -> Renderer:
    """A renderer for the config's layout: HRTF (binaural) or VBAP over its speakers;
    `hrirs` saves loading the config's set again (it takes most of a second)."""
    if config.layout == "binaural":
        from carlaverse.audio.binaural import Binaural
        from carlaverse.audio.hrtf import load_hrirs

        hrirs = hrirs or load_hrirs(config.hrtf, config.sample_rate_hz)
        return Renderer(config, Binaural(hrirs, fft_size(config.block_size)))
    from carlaverse.audio.panning import Panned

    return Renderer(config, Panned(config.layout, config.sample_rate_hz))


def layout_channels(layout: str) -> int:
    """Output channels of a layout: 2 for binaural, one per speaker otherwise."""
    from carlaverse.audio.panning import layout_azimuths

    return 2 if layout == "binaural" else len(layout_azimuths(layout))
