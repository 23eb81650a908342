"""How loud things are: engines, tyres and the weather, as columns over every actor at once.

The authority only needs what a renderer cannot know: how fast an engine turns, how hard it
works and how loud a source is at 1 m. The numbers are typical road-traffic values, not one
vehicle's: an engine's level rises ~30 dB per decade of engine speed (its firing rate) and up
to `load_db` with load; tyre-road noise rises ~35 dB per decade of speed and a few dB on a
wet road (CNOSSOS-EU rolling noise, per vehicle class). A car at 50 km/h is then ~84 dB at
1 m from its tyres, i.e. ~66 dB at 7.5 m, the order of a measured pass-by.

Every function takes and returns numpy arrays, one entry per actor, indexed by the actor-kind
code of `messages.ACTOR_KINDS`; kinds without an engine (bicycles, pedestrians) get NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from carlaverse.messages import ACTOR_KINDS


@dataclass(frozen=True, slots=True)
class EngineModel:
    """A combustion engine behind a gearbox that shifts up at `shift_rpm`."""

    idle_rpm: float  # [rpm]
    shift_rpm: float  # [rpm] upshift point
    gear_top_mps: tuple[float, ...]  # [m/s] road speed at shift_rpm in each gear
    idle_level_db: float  # [dB SPL] at 1 m, idling without load
    full_accel_mps2: float  # [m/s²] acceleration that takes full load
    rpm_db_per_decade: float = 30.0  # [dB] level rise per tenfold engine speed
    load_db: float = 8.0  # [dB] full load over no load


@dataclass(frozen=True, slots=True)
class TyreModel:
    level_at_ref_db: float  # [dB SPL] at 1 m, dry road, at REF_SPEED_MPS
    db_per_decade: float = 35.0  # [dB] level rise per tenfold speed
    wet_db: float = 5.0  # [dB] extra on a fully wet road


REF_SPEED_MPS = 13.89  # [m/s] 50 km/h, where tyre levels are given
MIN_ROLLING_MPS = 1.0  # [m/s] slower than this, tyres are not heard over the engine
MIN_SPEED_MPS = 0.5  # [m/s] below this a vehicle stands (idle, no cruise load)

ENGINES: dict[str, EngineModel] = {
    "car": EngineModel(800, 3000, (7, 12, 18, 25, 33, 45), 68.0, 3.0),
    "van": EngineModel(800, 3000, (6, 11, 17, 24, 32), 70.0, 2.0),
    "truck": EngineModel(600, 1800, (3, 5, 8, 11, 15, 19, 24, 28), 80.0, 1.0),
    "bus": EngineModel(600, 2000, (5, 9, 14, 20, 26), 78.0, 1.2),
    "motorcycle": EngineModel(1200, 6000, (8, 14, 20, 27, 35, 45), 78.0, 4.0, 35.0),
    "other": EngineModel(800, 3000, (7, 12, 18, 25, 33, 45), 68.0, 3.0),
}
TYRES: dict[str, TyreModel] = {
    "car": TyreModel(84.0),
    "van": TyreModel(86.0),
    "truck": TyreModel(92.0),
    "bus": TyreModel(91.0),
    "motorcycle": TyreModel(80.0),
    "bicycle": TyreModel(62.0, 30.0, 3.0),
    "other": TyreModel(84.0),
}


def _column(table: dict, attr: str) -> np.ndarray:
    """One model attribute per actor-kind code; NaN where the kind has no model."""
    return np.array([getattr(table[k], attr) if k in table else np.nan for k in ACTOR_KINDS])


@dataclass(frozen=True, slots=True)
class EngineColumns:
    rpm: np.ndarray  # [rpm]
    load: np.ndarray  # 0..1
    level_db: np.ndarray  # [dB SPL] at 1 m


class EngineBank:
    """Every kind's engine model as lookup columns, built once."""

    def __init__(self) -> None:
        self.has_engine = np.array([k in ENGINES for k in ACTOR_KINDS])
        self._idle, self._shift = _column(ENGINES, "idle_rpm"), _column(ENGINES, "shift_rpm")
        self._level = _column(ENGINES, "idle_level_db")
        self._full_accel = _column(ENGINES, "full_accel_mps2")
        self._rpm_db = _column(ENGINES, "rpm_db_per_decade")
        self._load_db = _column(ENGINES, "load_db")
        gears = max(len(e.gear_top_mps) for e in ENGINES.values())
        # [m/s] per kind and gear; a kind with fewer gears repeats its top gear.
        self._gear_top = np.array(
            [
                _padded(ENGINES[k].gear_top_mps, gears) if k in ENGINES else [np.nan] * gears
                for k in ACTOR_KINDS
            ]
        )

    def run(self, kind: np.ndarray, speed: np.ndarray, accel: np.ndarray) -> EngineColumns:
        """Engine speed, load and level for actors of `kind` at `speed` [m/s], `accel` [m/s²]."""
        tops = self._gear_top[kind]  # (n, gears)
        gear = np.minimum((speed[:, None] > tops * 0.95).sum(axis=1), tops.shape[1] - 1)
        top = tops[np.arange(len(kind)), gear]
        idle = self._idle[kind]
        rpm = np.clip(self._shift[kind] * speed / top, idle, self._shift[kind] * 1.2)
        cruise = np.where(speed > MIN_SPEED_MPS, 0.1 + 0.5 * (speed / tops[:, -1]) ** 2, 0.0)
        load = np.clip(cruise + accel / self._full_accel[kind], 0.0, 1.0)
        level = self._level[kind] + self._rpm_db[kind] * np.log10(rpm / idle)
        return EngineColumns(rpm, load, level + self._load_db[kind] * load)


class TyreBank:
    """Every kind's tyre-road model as lookup columns, built once."""

    def __init__(self) -> None:
        self.has_tyres = np.array([k in TYRES for k in ACTOR_KINDS])
        self._ref, self._slope = _column(TYRES, "level_at_ref_db"), _column(TYRES, "db_per_decade")
        self._wet = _column(TYRES, "wet_db")

    def level_db(self, kind: np.ndarray, speed: np.ndarray, wetness: float) -> np.ndarray:
        """[dB SPL] at 1 m for actors of `kind` rolling at `speed` [m/s] (≥ MIN_ROLLING_MPS)."""
        ratio = np.maximum(speed, MIN_ROLLING_MPS) / REF_SPEED_MPS
        return self._ref[kind] + self._slope[kind] * np.log10(ratio) + self._wet[kind] * wetness


def _padded(values: tuple[float, ...], n: int) -> list[float]:
    return [*values, *[values[-1]] * (n - len(values))]


# --------------------------------------------------------------------------- weather, areas

RAIN_MIN = 0.02  # precipitation below which rain is not heard
WIND_MIN_MPS = 1.0  # [m/s] calmer than this, wind is not heard


def rain_level_db(precipitation: float) -> float:
    """[dB SPL] around the listener: ~45 dB drizzle to ~75 dB downpour."""
    return 45.0 + 30.0 * precipitation


def wind_intensity(wind_mps: float) -> float:
    return min(wind_mps / 20.0, 1.0)  # a gale (20 m/s) is full intensity


def wind_level_db(wind_mps: float) -> float:
    """[dB SPL] at the ear: ~47 dB at 3 m/s, ~60 dB at 10 m/s, ~71 dB at 20 m/s."""
    return 35.0 + 40.0 * math.log10(1.0 + wind_mps / 3.0)


def leaves_intensity(wind_mps: float) -> float:
    return min(0.1 + wind_mps / 15.0, 1.0)  # a faint rustle even in calm air


def leaves_level_db(intensity: float) -> float:
    return 45.0 + 20.0 * intensity  # [dB SPL] 1 m from the foliage


def water_intensity(wind_mps: float) -> float:
    return min(0.3 + wind_mps / 20.0, 1.0)  # lapping that waves make louder


def water_level_db(intensity: float) -> float:
    return 50.0 + 15.0 * intensity  # [dB SPL] 1 m from the shore
