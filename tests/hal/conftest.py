from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.hal.sdl import VirtualJoystick


@pytest.fixture
def virtual_wheel(monkeypatch: pytest.MonkeyPatch) -> Iterator[VirtualJoystick]:
    """A real SDL virtual wheel: 4 axes, 6 buttons, 1 hat."""
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    pytest.importorskip("pygame")
    joystick = VirtualJoystick(axes=4, buttons=6, hats=1)
    yield joystick
    joystick.detach()
