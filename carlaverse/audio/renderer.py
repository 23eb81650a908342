"""The spatial audio renderer: emitters in, one block of multi-channel audio out.

Per block (all emitters at once, as numpy arrays):
 1. drive values glide, positions dead-reckon to the block's end;
 2. the travel time τ of each emitter's sound (`propagation.travel_time_s`), from where it
    left the source; 1/r spreading and ISO 9613-1 air absorption (`air`) for that distance;
 3. each source renders a block (`sources`), goes through its delay line read at t − τ(t),
    ramped over the block (the Doppler shift);
 4. overlap-save spectra of every emitter, times its gain and absorption, mixed into the
    output channels by the spatialiser (HRTF or VBAP), twice: with the block's old and new
    parameters; back to time and crossfaded over the block, so a change of direction, level
    or filter never clicks;
 5. a master limiter keeps peaks under full scale.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from carlaverse.audio.air import (
    AirAbsorption,
    one_pole_response,
    speed_of_sound_mps,
    unit_delays,
)
from carlaverse.audio.config import AudioConfig
from carlaverse.audio.hrtf import TAPS, HrirSet
from carlaverse.audio.limiter import Limiter
from carlaverse.audio.listener import ListenerPose
from carlaverse.audio.propagation import MIN_DISTANCE_M, DelayLines, travel_time_s
from carlaverse.audio.scene import FADING, SCENE, EmitterLike, EmitterSlots
from carlaverse.audio.sources import Drive, SourceBank

POLE_TAIL = 256  # [samples] FFT history kept for the absorption pole's decay (≤ 0.97^256)


@dataclass(frozen=True)
class Heard:
    """Per live emitter this block: what the spatialiser and the gains were made from."""

    slots: np.ndarray
    response: np.ndarray  # (E × F) complex: gain × absorption
    state: object  # the spatialiser's per-emitter state


def fft_size(block: int) -> int:
    return 1 << math.ceil(math.log2(block + TAPS + POLE_TAIL))


class Renderer:
    """Renders blocks for one listener; `spatialiser` is binaural.Binaural or panning.Panned."""

    def __init__(self, config: AudioConfig, spatialiser: object) -> None:
        self.config = config
        self.spatial = spatialiser
        self.channels: int = spatialiser.channels  # type: ignore[attr-defined]
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
        self.frames = np.zeros((capacity, self.n_fft), dtype=np.float32)
        self.tau_s = np.zeros(capacity)
        self.response = np.zeros((capacity, self.n_fft // 2 + 1), dtype=np.complex64)
        self.spatial_state = spatialiser.silent(capacity)  # type: ignore[attr-defined]
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
        self.t = t_end
        self.blocks += 1
        return self.limiter.process(out.T)

    def _start_fresh(self) -> None:
        fresh = self.slots.take_fresh()
        if fresh.size == 0:
            return
        self.sources.reset(fresh)
        self.delays.clear(fresh)
        self.frames[fresh] = 0.0
        self.response[fresh] = 0.0  # fades in from silence over its first block
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
        spectra = self._spectra(live, delayed)
        old_state = self.spatial.take(self.spatial_state, live)  # type: ignore[attr-defined]
        mixed = np.stack([
            self.spatial.mix(spectra * self.response[live], old_state),  # type: ignore[attr-defined]
            self.spatial.mix(spectra * heard.response, heard.state),  # type: ignore[attr-defined]
        ])  # fmt: skip
        old, new = np.fft.irfft(mixed, self.n_fft, axis=-1)[..., -self.block :]
        self._keep(heard)
        return old + (new - old) * self._fade_in[None, :]

    def _heard(self, live: np.ndarray, emitted_from: np.ndarray, tau: np.ndarray) -> Heard:
        """Gain, absorption and direction of each emitter's sound as it reaches the ears."""
        distance = np.maximum(tau * self.c_mps, 1e-6)
        amplitude = 10.0 ** ((self.slots.level_db[live] - self.config.full_scale_db_spl) / 20.0)
        gain = amplitude / np.maximum(distance, MIN_DISTANCE_M)
        gain[(self.slots.state[live] == FADING) | (distance > self.config.max_distance_m)] = 0.0
        flat, pole = self.air.at(distance)
        response = one_pole_response(pole, self._delays) * (gain * flat)[:, None].astype(np.float32)
        head = (emitted_from / distance[:, None]) @ self.listener.rotation  # world → head
        extent = self.slots.extent_m[live]
        diffuse = np.where(extent > 0.0, extent / (extent + distance), 0.0)
        return Heard(live, response, self.spatial.state(head, diffuse))  # type: ignore[attr-defined]

    def _spectra(self, live: np.ndarray, delayed: np.ndarray) -> np.ndarray:
        """Overlap-save: each slot's last n_fft samples, shifted on by one block."""
        frames = self.frames[live]
        frames[:, : -self.block] = frames[:, self.block :]
        frames[:, -self.block :] = delayed
        self.frames[live] = frames
        return np.fft.rfft(frames, axis=1).astype(np.complex64)

    def _keep(self, heard: Heard) -> None:
        """This block's parameters become the next block's old ones; faded slots free."""
        self.response[heard.slots] = heard.response
        _assign(self.spatial_state, heard.slots, heard.state)
        faded = heard.slots[self.slots.state[heard.slots] == FADING]
        if faded.size:
            self.slots.release(faded)


def _assign(state: object, slots: np.ndarray, new: object) -> None:
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

    return Renderer(config, Panned(config.layout))


def layout_channels(layout: str) -> int:
    """Output channels of a layout: 2 for binaural, one per speaker otherwise."""
    from carlaverse.audio.panning import layout_azimuths

    return 2 if layout == "binaural" else len(layout_azimuths(layout))
