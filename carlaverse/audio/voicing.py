"""How each kind of source sounds: the constants of the procedural generators.

Band weights are per octave band, 63 Hz .. 8 kHz (`noise.BAND_CENTRES_HZ`).
"""

from __future__ import annotations

import numpy as np

from carlaverse.messages import AUDIO_KINDS, SIREN_PATTERNS

KINDS = AUDIO_KINDS  # a kind's code in the renderer is its index here
WAIL, YELP, HI_LO = (SIREN_PATTERNS.index(p) for p in ("wail", "yelp", "hi-lo"))

ENGINE_CYLINDERS = 4  # a remote car's engine; four-stroke: it fires cylinders/2 per turn
# Orders of the firing frequency and their amplitudes at no load; load brightens the sound.
ENGINE_ORDERS = np.array([0.5, 1.0, 1.5, 2.0, 3.0, 4.0])
ENGINE_AMPLITUDES = np.array([0.35, 1.0, 0.3, 0.5, 0.25, 0.15])
ENGINE_LOAD_TILT = np.array([0.2, 0.5, 1.0, 1.5, 2.5, 3.5])  # extra gain per unit load
ENGINE_NOISE = np.array([0.0, 0.1, 0.3, 0.6, 1.0, 0.8, 0.4, 0.1])  # intake/exhaust hiss
ENGINE_NOISE_SHARE = 0.25  # hiss RMS relative to the harmonics, times (0.2 + load)

SIREN_HARMONICS = np.array([1.0, 1 / 3, 1 / 5])  # odd harmonics: a horn-like square-ish tone
WAIL_HZ = (650.0, 1350.0)  # [Hz] the sweep of wail and yelp
WAIL_PERIOD_S, YELP_PERIOD_S = 5.0, 0.35  # [s] up and down once
HI_LO_HZ, HI_LO_PERIOD_S = (440.0, 585.0), 1.5  # two tones, each for half the period

TYRE_DRY = np.array([0.05, 0.15, 0.35, 0.7, 1.0, 0.6, 0.25, 0.08])
TYRE_WET = np.array([0.0, 0.0, 0.05, 0.15, 0.4, 0.9, 1.0, 0.7])  # spray hiss
TYRE_SHIFT_MPS = (5.0, 40.0)  # [m/s] the roar rises one octave over this speed range

# Noisy ambience: bands, gust time constant [s], gust depth at intensity 0 and added at 1.
AMBIENCE = {
    "leaves": (np.array([0.0, 0.02, 0.05, 0.2, 0.6, 1.0, 0.9, 0.6]), 1.5, 0.3, 0.4),
    "water": (np.array([0.1, 0.4, 0.9, 1.0, 0.7, 0.4, 0.2, 0.1]), 0.08, 0.2, 0.2),  # babble
    "rain": (np.array([0.05, 0.1, 0.2, 0.4, 0.7, 1.0, 1.0, 0.8]), 0.5, 0.1, 0.1),
    "wind": (np.array([1.0, 0.8, 0.5, 0.3, 0.15, 0.08, 0.04, 0.02]), 2.0, 0.3, 0.5),
}

CONSTRUCTION_HIT = np.array([0.1, 0.3, 0.6, 0.9, 1.0, 0.8, 0.5, 0.3])
CONSTRUCTION_RUMBLE = np.array([1.0, 0.9, 0.5, 0.25, 0.1, 0.05, 0.0, 0.0])
BLOWS_HZ = (0.5, 4.0)  # [1/s] hammer blows per second at intensity 0 and 1
CLANK_HZ = np.array([1320.0, 2170.0, 3460.0])  # a struck steel plate's partials
HIT_DECAY_S, CLANK_DECAY_S = 0.04, 0.12  # [s] envelope time constants of a blow
BLOW_VARIANTS = 8  # different blows, made once; each blow plays one at random
