"""A real SDL virtual joystick, made through the SDL library pygame ships, so the pygame
backend and `carlaverse doctor` are tested against SDL itself rather than a mock."""

from __future__ import annotations

import ctypes
import glob
from pathlib import Path

import pytest

SDL_JOYSTICK_TYPE_WHEEL = 2


class VirtualJoystick:
    def __init__(self, axes: int, buttons: int, hats: int) -> None:
        import pygame

        self.sdl = load_sdl(pygame)
        self.sdl.SDL_JoystickOpen.restype = ctypes.c_void_p
        self.sdl.SDL_JoystickSetVirtualAxis.argtypes = [
            ctypes.c_void_p,
            ctypes.c_int,
            ctypes.c_int16,
        ]
        self.sdl.SDL_JoystickSetVirtualButton.argtypes = [
            ctypes.c_void_p,
            ctypes.c_int,
            ctypes.c_uint8,
        ]
        self.sdl.SDL_JoystickSetVirtualHat.argtypes = [
            ctypes.c_void_p,
            ctypes.c_int,
            ctypes.c_uint8,
        ]
        self.sdl.SDL_JoystickClose.argtypes = [ctypes.c_void_p]
        pygame.display.init()
        pygame.joystick.init()
        self.index = self.sdl.SDL_JoystickAttachVirtual(
            SDL_JOYSTICK_TYPE_WHEEL, axes, buttons, hats
        )
        if self.index < 0:
            pytest.skip("SDL refused to attach a virtual joystick")
        self.handle = self.sdl.SDL_JoystickOpen(self.index)
        pygame.event.pump()

    def axis(self, index: int, value: float) -> None:
        raw = max(-32768, min(32767, round(value * 32767)))
        self.sdl.SDL_JoystickSetVirtualAxis(self.handle, index, raw)

    def button(self, index: int, pressed: bool) -> None:
        self.sdl.SDL_JoystickSetVirtualButton(self.handle, index, int(pressed))

    def hat(self, index: int, bits: int) -> None:
        self.sdl.SDL_JoystickSetVirtualHat(
            self.handle, index, bits
        )  # 1 up, 2 right, 4 down, 8 left

    def detach(self) -> None:
        self.sdl.SDL_JoystickClose(self.handle)
        self.sdl.SDL_JoystickDetachVirtual(self.index)


def load_sdl(pygame) -> ctypes.CDLL:
    """The libSDL2 pygame itself loaded (same process-wide instance)."""
    package = Path(pygame.__file__).parent
    candidates = glob.glob(str(package.parent / "pygame.libs" / "libSDL2-*.so*"))
    candidates += glob.glob(str(package / ".dylibs" / "libSDL2*.dylib"))
    for candidate in candidates:
        return ctypes.CDLL(candidate)
    pytest.skip("pygame's bundled SDL library not found (pygame not from a wheel?)")
