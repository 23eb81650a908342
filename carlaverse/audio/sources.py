"""Procedural sound sources, one generator per emitter kind, each rendering a batch of
emitters of its kind per block (E × block samples, RMS ≈ 1; the renderer applies level_db).

Nothing is sampled from recordings: engines are harmonics of their firing frequency, sirens
swept or alternating tones, the rest shaped noise (`noise.NoiseBands`) with its own motion.
Drive values (`drive_a`, `drive_b`) mean what messages.AUDIO_DRIVE_MEANING says; each
arrives as the block's start and end value and is ramped per sample, so nothing zips.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carlaverse.audio import voicing as v
from carlaverse.audio.noise import BAND_CENTRES_HZ, Gusts, NoiseBands
from carlaverse.audio.wavetables import SIREN_ROW, Wavetables, engine_row

TWO_PI = 2.0 * np.pi
NOISE_BANDS = len(BAND_CENTRES_HZ)


@dataclass(frozen=True)
class Voice:
    """A tone of the wavetables, per emitter of one batch: its frequency at the block's start
    and end, the table row and the blend to the next row, and its amplitude."""

    hz0: np.ndarray
    hz1: np.ndarray
    row: np.ndarray
    frac: np.ndarray
    amplitude: np.ndarray


# What a generator returns: its tonal part (a Voice, samples E × block, or None) and its
# noise band gains (E × bands) at the block's start and end.
Generated = tuple[Voice | np.ndarray | None, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Drive:
    """Per emitter of one batch: drive values at the block's start and end."""

    a0: np.ndarray
    a1: np.ndarray
    b0: np.ndarray
    b1: np.ndarray

    def part(self, sel: np.ndarray) -> Drive:
        return Drive(self.a0[sel], self.a1[sel], self.b0[sel], self.b1[sel])


class SourceBank:
    """The state of every emitter's generator (phases, noise offsets, gusts, blow timers)."""

    def __init__(self, capacity: int, sample_rate_hz: int, block: int, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.rate = float(sample_rate_hz)
        self.block = block
        self.noise = NoiseBands(sample_rate_hz, self.rng)
        self.tables = Wavetables(self.rate)
        self.phase = np.zeros(capacity)  # [rad] tone phase, wrapped at 4π (half orders)
        self.clock_s = np.zeros(capacity)  # [s] since the emitter appeared: siren patterns
        self.offset = np.zeros(capacity, dtype=np.int64)  # into the noise tables
        self.since_blow = np.zeros(capacity, dtype=np.int64)  # [samples] construction
        self.blow_variant = np.zeros(capacity, dtype=np.int64)  # which recorded-once blow
        self.cylinders = np.full(capacity, float(v.ENGINE_CYLINDERS))
        self.gusts = Gusts(capacity, self.rng)
        # Band gains of fixed spectra, scaled once to RMS 1.
        self._bands = {name: self.noise.unit_power(bands)[0] for name, bands in (
            ("engine", v.ENGINE_NOISE), ("hit", v.CONSTRUCTION_HIT),
            ("rumble", v.CONSTRUCTION_RUMBLE),
            )}  # fmt: skip
        self._generators = {
            "engine": self._engine,
            "tyres": self._tyres,
            "siren": self._siren,
            "construction": self._construction,
        }  # every other kind is ambience, rendered together
        self._ambient = _AmbienceTable(self.noise)
        self._blow_table = self._make_blows()
        self._sample_index = np.arange(block)
        self._tyre_dry_shifted = np.roll(v.TYRE_DRY, 1)  # one octave up
        n = np.arange(1, block + 1, dtype=np.float32)
        # Per sample: its index, the ramp's running sum, 1 (for the carried phase).
        self._phase_basis = np.stack([n, n * (n + 1) / (2 * block), np.ones(block)]).astype(
            np.float32
        )

    def reset(self, slots: np.ndarray) -> None:
        """Fresh state for emitters that just appeared."""
        n = len(slots)
        self.phase[slots] = self.rng.uniform(0.0, 2 * TWO_PI, n)
        self.clock_s[slots] = self.rng.uniform(0.0, v.WAIL_PERIOD_S, n)
        self.offset[slots] = self.rng.integers(0, self.noise.samples, n)
        self.since_blow[slots] = self.tables.blow_samples
        self.cylinders[slots] = v.ENGINE_CYLINDERS
        self.gusts.reset(slots)

    def render(self, slots: np.ndarray, kinds: np.ndarray, drive: Drive) -> np.ndarray:
        """(E × block) float32, one row per slot in `slots`; `kinds` index voicing.KINDS.

        Each generator returns its tonal part (or None) and its noise band gains at the
        block's start and end; the tones of all engines and sirens are then read in one go,
        and so is the noise of all emitters."""
        n = len(slots)
        gains0, gains1 = np.zeros((n, NOISE_BANDS)), np.zeros((n, NOISE_BANDS))
        voices: list[tuple[np.ndarray, Voice]] = []
        samples: list[tuple[np.ndarray, np.ndarray]] = []
        ambient = self._ambient.codes[kinds] >= 0
        for code in np.flatnonzero(np.bincount(kinds[~ambient], minlength=len(v.KINDS))):
            sel = np.flatnonzero(kinds == code)
            kind = v.KINDS[code]
            part, gains0[sel], gains1[sel] = self._generators[kind](slots[sel], drive.part(sel))
            if isinstance(part, Voice):
                voices.append((sel, part))
            elif part is not None:
                samples.append((sel, part))
        if ambient.any():
            sel = np.flatnonzero(ambient)
            gains0[sel], gains1[sel] = self._ambience(slots[sel], drive.a1[sel], kinds[sel])
        out = self.noise.read(self.offset[slots], gains0, gains1, self.block)
        if voices:
            samples.append(self._voice(slots, voices))
        for sel, part in samples:
            out[sel] += part
        self.offset[slots] = (self.offset[slots] + self.block) % self.noise.samples
        self.clock_s[slots] += self.block / self.rate
        return out

    # ------------------------------------------------------------------ tones

    def _voice(
        self, slots: np.ndarray, voices: list[tuple[np.ndarray, Voice]]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Every tonal emitter's block, in one table lookup: (rows, E × block samples)."""
        sel = np.concatenate([s for s, _ in voices])
        part = {name: np.concatenate([getattr(voice, name) for _, voice in voices])
                for name in Voice.__dataclass_fields__}  # fmt: skip
        phase = self._tone_phase(slots[sel], part["hz0"], part["hz1"])
        amplitude = part["amplitude"].astype(np.float32)[:, None]
        return sel, self.tables.tone(phase, part["row"], part["frac"]) * amplitude

    def _tone_phase(self, slots: np.ndarray, hz0: np.ndarray, hz1: np.ndarray) -> np.ndarray:
        """Running phase (E × block) [rad, from the carried phase in 0..4π on, unwrapped: the
        table lookup wraps it] of a frequency ramped from hz0 to hz1 (E,) over the block:
        the sum of the ramp in closed form, no cumulative sum: one matrix product of each
        emitter's (step, step change, carried phase) with the per-sample basis."""
        step = TWO_PI / self.rate
        terms = np.stack([hz0 * step, (hz1 - hz0) * step, self.phase[slots]], axis=1)
        phase = terms.astype(np.float32) @ self._phase_basis
        # The block's end in double precision: the phase carried on never drifts.
        end = self.phase[slots] + TWO_PI / self.rate * (
            hz0 * self.block + (hz1 - hz0) * (self.block + 1) / 2
        )
        self.phase[slots] = np.mod(end, 2 * TWO_PI)
        return phase

    def _engine(self, slots: np.ndarray, d: Drive) -> Generated:
        """Harmonics of the firing frequency (rpm/60 · cylinders/2), brighter under load,
        with intake and exhaust hiss."""
        per_rpm = self.cylinders[slots] / 120.0  # firing frequency per rpm [Hz]
        load = np.clip(0.5 * (d.b0 + d.b1), 0.0, 1.0)
        share = v.ENGINE_NOISE_SHARE * (0.2 + load)
        norm = 1.0 / np.sqrt(1.0 + share**2)
        hiss = self._bands["engine"] * (share * norm)[:, None]
        row, frac = engine_row(load)
        return Voice(d.a0 * per_rpm, d.a1 * per_rpm, row, frac, norm), hiss, hiss

    def _siren(self, slots: np.ndarray, d: Drive) -> Generated:
        """wail / yelp: a triangle sweep; hi-lo: two alternating tones (each glides into the
        other over one block, as a real two-tone horn does)."""
        n = len(slots)
        t0 = self.clock_s[slots]
        pattern = np.rint(d.a1).astype(int)
        hz = _siren_hz(np.concatenate([t0, t0 + self.block / self.rate]), np.tile(pattern, 2))
        hz0, hz1 = hz[:n], hz[n:]
        silent = np.zeros((n, NOISE_BANDS))
        row = np.full(n, SIREN_ROW)
        return Voice(hz0, hz1, row, np.zeros(n), np.ones(n)), silent, silent

    # ------------------------------------------------------------------ noise

    def _tyres(self, slots: np.ndarray, d: Drive) -> Generated:
        """Road roar rising in pitch with speed; wetness adds spray hiss."""
        n = len(slots)
        both = self._tyre_bands(np.concatenate([d.a0, d.a1]), np.concatenate([d.b0, d.b1]))
        return None, both[:n], both[n:]

    def _tyre_bands(self, speed_mps: np.ndarray, wetness: np.ndarray) -> np.ndarray:
        low, high = v.TYRE_SHIFT_MPS
        shift = np.clip((speed_mps - low) / (high - low), 0.0, 1.0)[:, None]
        dry = (1.0 - shift) * v.TYRE_DRY + shift * self._tyre_dry_shifted
        return self.noise.unit_power(dry + 1.5 * np.clip(wetness, 0.0, 1.0)[:, None] * v.TYRE_WET)

    def _ambience(self, slots: np.ndarray, intensity: np.ndarray,
                  kinds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """Leaves, water, rain, wind: shaped noise swelling in gusts; intensity deepens them.
        Band gains at the block's start and end."""
        row = self._ambient.codes[kinds]
        depth = self._ambient.depth0[row] + self._ambient.depth1[row] * intensity
        g0, g1 = self.gusts.step(slots, self.block / self.rate, self._ambient.tau_s[row], depth)
        gains = self._ambient.bands[row]
        return gains * g0[:, None], gains * g1[:, None]

    def _construction(self, slots: np.ndarray, d: Drive) -> Generated:
        """Hammer blows at random intervals (more with intensity) over a machine rumble."""
        where = self._blows(slots, v.BLOWS_HZ[0] + (v.BLOWS_HZ[1] - v.BLOWS_HZ[0]) * d.a1)
        rumble = np.broadcast_to(0.3 * self._bands["rumble"], (len(slots), NOISE_BANDS))
        return self._blow_table.take(where), rumble, rumble

    def _make_blows(self) -> np.ndarray:
        """BLOW_VARIANTS hammer blows made once (band noise under a fast decay, and the ring
        of the plate), flattened; a blow plays one of them from its start."""
        n = self.tables.blow_samples + 1
        starts = self.rng.integers(0, self.noise.samples - n, v.BLOW_VARIANTS)
        hit = np.stack([self.noise.tables[s : s + n] @ self._bands["hit"] for s in starts])
        blows = 1.5 * self.tables.hit_envelope * hit + 0.5 * self.tables.clank
        blows[:, -1] = 0.0  # the end of a blow, where `since` rests until the next one
        return blows.astype(np.float32).ravel()

    def _blows(self, slots: np.ndarray, rate_hz: np.ndarray) -> np.ndarray:
        """Where each sample of the block is in the blow table (E × block): the running
        blow until a new one starts (at most one per block), which then plays from its start."""
        length = self.tables.blow_samples + 1
        blow = self.rng.random(len(slots)) < rate_hz * self.block / self.rate
        at = np.where(blow, self.rng.integers(0, self.block, len(slots)), self.block)[:, None]
        old = self.blow_variant[slots]
        new = np.where(blow, self.rng.integers(0, v.BLOW_VARIANTS, len(slots)), old)
        n = self._sample_index
        since = np.minimum(self.since_blow[slots, None] + n, length - 1)  # the running blow
        if blow.any():  # most blocks start none: a sample index per blow ahead (≥ 0.25 s)
            since = np.where(n >= at, np.minimum(n - at, length - 1), since)
        variant = np.where(n >= at, new[:, None], old[:, None]) if blow.any() else old[:, None]
        self.since_blow[slots] = np.minimum(since[:, -1] + 1, length - 1)
        self.blow_variant[slots] = new
        return variant * length + since


class _AmbienceTable:
    """voicing.AMBIENCE as arrays, indexed by a kind's row (codes: kind code → row, or −1)."""

    def __init__(self, noise: NoiseBands) -> None:
        names = list(v.AMBIENCE)
        self.codes = np.array([names.index(k) if k in names else -1 for k in v.KINDS])
        shapes = [v.AMBIENCE[k] for k in names]
        self.bands = np.concatenate([noise.unit_power(shape[0]) for shape in shapes])
        self.tau_s, self.depth0, self.depth1 = (np.array([s[i] for s in shapes]) for i in (1, 2, 3))


def _siren_hz(t: np.ndarray, pattern: np.ndarray) -> np.ndarray:
    """[Hz] of each siren at time `t` [s] for its pattern (index into SIREN_PATTERNS)."""
    period = np.where(pattern == v.YELP, v.YELP_PERIOD_S, v.WAIL_PERIOD_S)
    return np.where(pattern == v.HI_LO, _hi_lo(t), _sweep(t, period))


def _sweep(t: np.ndarray, period_s: np.ndarray) -> np.ndarray:
    """Triangle sweep over WAIL_HZ: up for half the period, down for the other half."""
    tri = 1.0 - np.abs(2.0 * np.mod(t / period_s, 1.0) - 1.0)
    return v.WAIL_HZ[0] + (v.WAIL_HZ[1] - v.WAIL_HZ[0]) * tri


def _hi_lo(t: np.ndarray) -> np.ndarray:
    high = np.mod(t / v.HI_LO_PERIOD_S, 1.0) < 0.5
    return np.where(high, v.HI_LO_HZ[1], v.HI_LO_HZ[0])
