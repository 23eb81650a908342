"""Head-related impulse responses: the MIT KEMAR set shipped in `slab`, or any SOFA file.

The KEMAR set (Gardner & Martin, MIT Media Lab 1994, "may be used freely with attribution")
is bundled inside the `slab` package (MIT licence) as a bz2 pickle of slab's own classes.
Importing slab would load PortAudio, so the file is read here with an unpickler that admits
only numpy arrays and two plain records in place of slab's classes: nothing else can run.
SOFA files (SimpleFreeFieldHRIR, HDF5 / netCDF-4) are read with h5py.

Directions follow SOFA: azimuth counter-clockwise from the front (90° = left), elevation up,
in degrees. Responses are resampled to the renderer's rate and cut to `TAPS` samples.
"""

from __future__ import annotations

import bz2
import importlib
import importlib.util
import math
import pickle
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

TAPS = 256  # [samples] kept per response; KEMAR holds 99.9 % of its energy in 347 @ 44.1 kHz
FADE_TAPS = 32  # [samples] half-Hann fade at the cut, so truncation adds no click
KEMAR = "kemar"
_SLAB_CLASSES = {("slab.hrtf", "HRTF"), ("slab.filter", "Filter")}


class HrtfError(ValueError):
    """An HRTF set is missing or unreadable; the message names the file and the fix."""


@dataclass(frozen=True)
class HrirSet:
    """Impulse responses (D × 2 × TAPS, left then right) for D directions."""

    sample_rate_hz: int
    azimuth_deg: np.ndarray  # (D,)
    elevation_deg: np.ndarray  # (D,)
    irs: np.ndarray  # (D, 2, TAPS) float32
    source: str  # where it came from, for reports

    def unit_vectors(self) -> np.ndarray:
        """(D × 3) directions in the head frame: x forward, y left, z up."""
        az, el = np.radians(self.azimuth_deg), np.radians(self.elevation_deg)
        return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)


def load_hrirs(name: str, sample_rate_hz: int) -> HrirSet:
    """`kemar`, or the path of a SOFA file; resampled to `sample_rate_hz`."""
    if name == KEMAR:
        rate, az, el, irs = _read_kemar()
    else:
        rate, az, el, irs = _read_sofa(Path(name))
    return HrirSet(sample_rate_hz, az, el, _conform(irs, rate, sample_rate_hz), name)


class _Record:
    """Stands in for slab's HRTF and Filter classes: keeps their attributes, runs nothing."""

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)


class _KemarUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> type:
        if (module, name) in _SLAB_CLASSES:
            return _Record
        if module.split(".")[0] == "numpy" and name in ("_reconstruct", "ndarray", "dtype"):
            return getattr(importlib.import_module(module), name)
        raise pickle.UnpicklingError(f"the KEMAR file refers to {module}.{name}, refused")


def kemar_path() -> Path:
    spec = importlib.util.find_spec("slab")
    if spec is None or not spec.submodule_search_locations:
        raise HrtfError("hrtf 'kemar' needs the slab package: pip install 'carlaverse[audio]'")
    return Path(next(iter(spec.submodule_search_locations))) / "data" / "mit_kemar_normal_pinna.bz2"


def _read_kemar() -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    path = kemar_path()
    try:
        with bz2.BZ2File(path) as f:
            record = _KemarUnpickler(f).load()
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError) as exc:
        raise HrtfError(f"cannot read the KEMAR set {path}: {exc}") from exc
    irs = np.stack([np.asarray(f.data, dtype=np.float64).T for f in record.data])  # D, 2, n
    sources = np.asarray(record.sources, dtype=np.float64)
    return float(record.samplerate), sources[:, 0], sources[:, 1], irs


def _read_sofa(path: Path) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    if not path.is_file():
        raise HrtfError(f"hrtf {path}: no such SOFA file (or use 'kemar')")
    try:
        import h5py
    except ModuleNotFoundError as exc:
        raise HrtfError("reading a SOFA file needs h5py: pip install 'carlaverse[audio]'") from exc
    try:
        with h5py.File(path, "r") as f:
            irs = np.asarray(f["Data.IR"], dtype=np.float64)  # M, R, N
            rate = float(np.asarray(f["Data.SamplingRate"]).ravel()[0])
            positions = np.asarray(f["SourcePosition"], dtype=np.float64)
            cartesian = f["SourcePosition"].attrs.get("Type", b"spherical")
    except (OSError, KeyError) as exc:
        raise HrtfError(f"hrtf {path}: not a SimpleFreeFieldHRIR SOFA file ({exc})") from exc
    if irs.ndim != 3 or irs.shape[1] != 2:
        raise HrtfError(f"hrtf {path}: Data.IR has shape {irs.shape}, expected (M, 2, N)")
    az, el = _angles(positions, _text(cartesian) == "cartesian")
    return rate, az, el, irs


def _text(value: bytes | str) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _angles(positions: np.ndarray, cartesian: bool) -> tuple[np.ndarray, np.ndarray]:
    if not cartesian:
        return positions[:, 0], positions[:, 1]
    x, y, z = positions[:, 0], positions[:, 1], positions[:, 2]
    return np.degrees(np.arctan2(y, x)), np.degrees(np.arctan2(z, np.hypot(x, y)))


def _conform(irs: np.ndarray, rate: float, target_hz: int) -> np.ndarray:
    """Resample to `target_hz`, cut to TAPS with a fade, as float32 (D, 2, TAPS)."""
    if not math.isclose(rate, target_hz):
        irs = _resample(irs, Fraction(target_hz / rate).limit_denominator(1000))
    out = np.zeros((*irs.shape[:2], TAPS))
    n = min(TAPS, irs.shape[-1])
    out[..., :n] = irs[..., :n]
    out[..., TAPS - FADE_TAPS :] *= np.hanning(2 * FADE_TAPS)[FADE_TAPS:]
    return out.astype(np.float32)


def _resample(irs: np.ndarray, ratio: Fraction) -> np.ndarray:
    """Band-limited resampling by `ratio` through the spectrum: the responses are zero-padded
    to a length the ratio maps onto whole samples (at least twice theirs, so the circular
    transform does not wrap), and the spectrum is cut or extended to the new length."""
    n = irs.shape[-1]
    padded = ratio.denominator * math.ceil(2 * n / ratio.denominator)
    resized = padded * ratio.numerator // ratio.denominator
    spectrum = np.fft.rfft(irs, padded, axis=-1)
    out = np.fft.irfft(spectrum, resized, axis=-1) * (resized / padded)
    return out[..., : math.ceil(n * ratio)]
