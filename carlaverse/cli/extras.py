"""Which `pip install` brings an optional package: the one table the command line reads.

The core install (`pip install carlaverse`) runs a node; each further part is an extra of
pyproject.toml. A command that stops on a ModuleNotFoundError of a package named here says in
one line which install brings it (`carlaverse.cli.main`); a module not named here is ours or
the core's, so its absence is a bug and keeps its traceback. tests/cli/test_missing_extras.py
holds this table to pyproject.toml's extras.
"""

from __future__ import annotations

# top-level import name -> the extra that installs its distribution
EXTRA_OF_MODULE: dict[str, str] = {
    "sumolib": "authority",
    "libsumo": "authority",
    "sumo": "authority",  # eclipse-sumo: the netconvert/netgenerate binaries
    "pygame": "input",
    "evdev": "evdev",
    "mcap": "record",
    "zstandard": "record",
    "lz4": "record",
    "rerun": "view",  # rerun-sdk
    "panda3d": "render",
    "direct": "render",  # Panda3D's own Python package
    "PIL": "render",  # pillow
    "imageio_ffmpeg": "render",
    "carla": "carla",
    "bleak": "bike",
    "serial": "bike",  # pyserial
    "xr": "xr",  # pyopenxr
    "pyarrow": "analysis",
    "matplotlib": "analysis",  # also in `body`, where mediapipe's own check names that extra
    "cv2": "body",  # opencv-python-headless
    "absl": "body",  # absl-py, for mediapipe
    "flatbuffers": "body",
    "certifi": "body",
    "slab": "audio",
    "h5py": "audio",
    "sounddevice": "audio",
    "scipy": "audio",
    "cryptography": "security",
    "starlette": "hmi",
    "uvicorn": "hmi",
    "websockets": "hmi",
    "nicegui": "launcher",
    "psutil": "launcher",
    "segno": "launcher",
    "osi3": "osi",  # osi-python: `record --osi`, `carlaverse osi`
    "pylsl": "study",  # Lab Streaming Layer (it ships liblsl): `record --lsl`, study streams
}
# mediapipe is no extra's: it requires opencv-contrib-python, a second cv2 beside the body
# extra's opencv-python-headless, so it is installed without its dependencies (README "Body pose").
MEDIAPIPE_INSTALL = "pip install 'carlaverse[body]' && pip install --no-deps 'mediapipe==1.2.2'"


def install_hint(module: str | None) -> str | None:
    """The install command that brings `module` (a dotted name), or None if no extra does."""
    top = (module or "").partition(".")[0]
    if top == "mediapipe":
        return MEDIAPIPE_INSTALL
    extra = EXTRA_OF_MODULE.get(top)
    return None if extra is None else f"pip install 'carlaverse[{extra}]'"
