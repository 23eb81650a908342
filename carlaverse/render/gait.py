"""Joint angles for walkers the world sends no skeleton of, and for a cyclist's legs.

Angles follow `figure`'s convention: (roll, pitch, yaw) [rad] per joint, pitch positive swings
a limb backward, a knee's or elbow's pitch turns the lower segment against the upper one.

Walking. Stride length (two steps, one full cycle) from dynamic similarity (Alexander, "Walking
and running", American Scientist 72, 1984; Nature 261, 1976): λ = 2.3 · h · (v² / (g·h))^0.3
with h the hip height. For h = 0.93 m at 1.37 m/s that is 1.33 m, a step of 0.67 m; Perry &
Burnfield (Gait Analysis, 2nd ed., 2010) give normal adults 1.37 m/s and a stride of 1.41 m
(a step of 0.71 m). At rest λ = 0: the legs stand together. The cycle's phase advances by
2π per stride walked. At double support the straight legs are a step apart at the feet, so each
hip swings ±asin(step / 2h); the swing knee bends up to 2.7 times that (about 60° at a normal
pace, Perry's peak swing flexion), the arms swing against the legs at 0.7 times it, and the
pelvis drops so that both feet stay on the ground when the legs are apart.

Pedalling. The crank turns once per `development` of road: one wheel circumference times the
gear ratio (chainring / sprocket teeth). A city bike's 42/20 on a 700C wheel (r = 0.34 m)
gives 4.5 m per turn, 67 rpm at 18 km/h. Each leg reaches from the hip to its pedal as a
two-link chain (thigh, shin) with the knee ahead of the line hip–pedal.
"""

from __future__ import annotations

import math

from carlaverse.render.frame import JointAngles

G = 9.81  # [m/s²]
STRIDE_K, STRIDE_EXP = 2.3, 0.3  # Alexander's λ/h = 2.3 (v²/gh)^0.3
KNEE_PER_HIP = 2.7  # peak swing knee flexion per hip amplitude (60° at 22°)
ARM_PER_HIP = 0.7  # shoulder swing per hip amplitude
ELBOW_RAD = 0.35  # [rad] forearm carried forward while walking (negative pitch)
NORMAL_WALK_MPS = 1.37  # [m/s] Perry & Burnfield's normal adult walking speed
GEAR_RATIO = 42 / 20  # chainring / sprocket of a city bike
CRANK_M = 0.17  # [m] crank length, hub to pedal axle


def stride_length(speed: float, hip_height_m: float) -> float:
    """λ = 2.3 · h · (v²/gh)^0.3 [m]: two steps, one full gait cycle (0 at rest)."""
    v = abs(speed)
    if v == 0.0:
        return 0.0
    return STRIDE_K * hip_height_m * (v * v / (G * hip_height_m)) ** STRIDE_EXP


def hip_amplitude(speed: float, hip_height_m: float) -> float:
    """[rad] each hip's swing either side of vertical: straight legs a step apart."""
    step = stride_length(speed, hip_height_m) / 2
    return math.asin(min(1.0, step / (2 * hip_height_m)))


def walking_angles(phase: float, speed: float, hip_height_m: float) -> JointAngles:
    """The joints at gait `phase` [rad]: 0 is mid-swing of the left leg, ±π/2 double support."""
    a = hip_amplitude(speed, hip_height_m)
    s, c = math.sin(phase), math.cos(phase)
    knee = KNEE_PER_HIP * a
    elbow = -ELBOW_RAD * min(1.0, abs(speed) / NORMAL_WALK_MPS)
    return {
        "left_hip": (0.0, -a * s, 0.0), "right_hip": (0.0, a * s, 0.0),
        "left_knee": (0.0, knee * max(0.0, c), 0.0),
        "right_knee": (0.0, knee * max(0.0, -c), 0.0),
        "left_shoulder": (0.0, ARM_PER_HIP * a * s, 0.0),
        "right_shoulder": (0.0, -ARM_PER_HIP * a * s, 0.0),
        "left_elbow": (0.0, elbow, 0.0), "right_elbow": (0.0, elbow, 0.0),
    }  # fmt: skip


def pelvis_drop(phase: float, speed: float, hip_height_m: float) -> float:
    """[m] how far the hips sink so the stance leg, swung by the hip angle, keeps its foot down."""
    a = hip_amplitude(speed, hip_height_m) * abs(math.sin(phase))
    return hip_height_m * (1.0 - math.cos(a))


def advance_phase(phase: float, walked_m: float, speed: float, hip_height_m: float) -> float:
    """The gait's phase [rad] after walking `walked_m` more at `speed`: 2π per stride."""
    stride = stride_length(speed, hip_height_m)
    if stride <= 0.0:
        return phase
    return phase + 2 * math.pi * walked_m / stride


def crank_angle(rolled_m: float, wheel_radius_m: float, ratio: float = GEAR_RATIO,
                start: float = 0.0) -> float:  # fmt: skip
    """[rad] the crank after the wheel rolled `rolled_m`: one turn per 2π·r·ratio of road."""
    return start + rolled_m / (wheel_radius_m * ratio)


def pedal(bottom_bracket: tuple[float, float], crank: float, crank_m: float = CRANK_M,
          ) -> tuple[float, float]:  # fmt: skip
    """(forward, up) [m] of the pedal on a crank at angle `crank` from top dead centre."""
    return (bottom_bracket[0] + crank_m * math.sin(crank),
            bottom_bracket[1] + crank_m * math.cos(crank))  # fmt: skip


def leg_to(hip: tuple[float, float], foot: tuple[float, float], thigh_m: float,
           shin_m: float) -> tuple[float, float]:  # fmt: skip
    """(hip pitch, knee pitch) [rad] that put the foot at `foot` (forward, up) [m], knee ahead.

    A figure's limb hangs straight down at rest; pitch swings it backward, so a thigh pointing
    forward has negative pitch and a bent knee positive."""
    dy, dz = foot[0] - hip[0], foot[1] - hip[1]
    reach = min(math.hypot(dy, dz), (thigh_m + shin_m) * (1 - 1e-9))
    reach = max(reach, abs(thigh_m - shin_m) * (1 + 1e-9))
    toward = math.atan2(dy, -dz)  # the line hip→foot, from straight down, forward positive
    at_hip = math.acos((thigh_m**2 + reach**2 - shin_m**2) / (2 * thigh_m * reach))
    at_knee = math.acos((thigh_m**2 + shin_m**2 - reach**2) / (2 * thigh_m * shin_m))
    return -(toward + at_hip), math.pi - at_knee
