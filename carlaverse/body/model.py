"""The pose landmarker model, built offline from the models a mediapipe 0.10 wheel bundles.

mediapipe 1.x ships the Tasks runtime but no model, and nothing may be downloaded at run
time. The mediapipe 0.10.21 wheel for CPython 3.11 on the package index carries the legacy
BlazePose models `pose_detection.tflite` and `pose_landmark_full.tflite`. A Tasks-API
`pose_landmarker.task` is a zip of the two under the names the Tasks graph looks for, each with
input-normalization metadata (the detector wants pixels in [−1, 1], the landmark model in
[0, 1]). `build()` makes that file, reproducibly:

1. `pip download` the pinned wheel (no dependencies, this exact platform tag, whatever the
   host), or take one given with `--wheel`; check its SHA-256;
2. extract the two models and check their SHA-256;
3. add the normalization metadata (`tflite_metadata`);
4. zip them stored, 16-byte aligned, with fixed timestamps, so the same inputs give the same
   bytes, and move it into place atomically.

The models are Google's, under the Apache License 2.0 (the wheel's licence).
Run it as `carlaverse body build-model`; the file lands in the user cache
(`$XDG_CACHE_HOME/carlaverse/models/`, else `~/.cache/...`) unless `--out` says otherwise.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from carlaverse.body.errors import PoseModelError

WHEEL_REQUIREMENT = "mediapipe==0.10.21"
WHEEL_NAME = "mediapipe-0.10.21-cp311-cp311-manylinux_2_28_x86_64.whl"
WHEEL_SHA256 = "05dc4a9e593655a79558d05d6227d31018c2537a4bd3362b51e230cf22aecfe3"
# `pip download` selects exactly that file on any host with these.
WHEEL_TAGS = ("--platform", "manylinux_2_28_x86_64", "--python-version", "3.11",
              "--implementation", "cp", "--abi", "cp311", "--only-binary=:all:")  # fmt: skip
TASK_NAME = "pose_landmarker_full.task"
ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed timestamps: a rebuild gives the same bytes
# Kept as the zip comment: where the file came from, checked before it is used. Bump the
# number when the build changes what it writes.
BUILD_ID = f"carlaverse pose task build 1 from {WHEEL_NAME} sha256:{WHEEL_SHA256}".encode()
ZIP_ALIGNMENT = 16  # [bytes] members start aligned so the runtime can map them in place


@dataclass(frozen=True)
class BundledModel:
    member: str  # path inside the wheel
    sha256: str
    task_name: str  # file name inside the .task that the Tasks graph expects
    mean: float  # input = (pixel − mean) / std
    std: float


MODELS = (
    BundledModel("mediapipe/modules/pose_detection/pose_detection.tflite",
                 "9ba9dd3d42efaaba86b4ff0122b06f29c4122e756b329d89dca1e297fd8f866c",
                 "pose_detector.tflite", 127.5, 127.5),  # pixels to [−1, 1]
    BundledModel("mediapipe/modules/pose_landmark/pose_landmark_full.tflite",
                 "e9a5c5cb17f736fafd4c2ec1da3b3d331d6edbe8a0d32395855aeb2cdfd64b9f",
                 "pose_landmarks_detector.tflite", 0.0, 255.0),  # pixels to [0, 1]
)  # fmt: skip


def default_path() -> Path:
    """Where the built model lives unless a config names another file."""
    cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(Path.home(), ".cache")
    return Path(cache) / "carlaverse" / "models" / TASK_NAME


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def download_wheel(into: Path) -> Path:
    """The pinned mediapipe 0.10 wheel, fetched by pip from the package index into `into`."""
    command = [sys.executable, "-m", "pip", "download", "--no-deps", "--quiet",
               "--dest", str(into), *WHEEL_TAGS, WHEEL_REQUIREMENT]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    wheel = into / WHEEL_NAME
    if done.returncode != 0 or not wheel.exists():
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise PoseModelError(f"could not download {WHEEL_REQUIREMENT} with pip ({last}); "
                             f"download {WHEEL_NAME} elsewhere and pass --wheel FILE")  # fmt: skip
    return wheel


def extract_models(wheel: Path) -> dict[BundledModel, bytes]:
    """The two pose models from the wheel, each checked against its pinned hash."""
    data = wheel.read_bytes()
    if _sha256(data) != WHEEL_SHA256:
        raise PoseModelError(f"{wheel}: SHA-256 {_sha256(data)} is not {WHEEL_NAME}'s "
                             f"{WHEEL_SHA256}; use the file from the package index")  # fmt: skip
    found = {}
    with zipfile.ZipFile(wheel) as archive:
        for model in MODELS:
            found[model] = archive.read(model.member)
            if _sha256(found[model]) != model.sha256:  # the wheel's hash covers this too
                raise PoseModelError(f"{wheel}: {model.member} has an unexpected SHA-256")
    return found


def task_bundle(models: dict[BundledModel, bytes]) -> bytes:
    """The .task file's bytes: each model with its normalization metadata, zipped stored."""
    from mediapipe.tasks.python.metadata.metadata_writers.model_asset_bundle_utils import (
        AlignZipFile,
    )

    from carlaverse.body.tflite_metadata import image_model_metadata, with_metadata

    with tempfile.TemporaryFile() as out:
        with AlignZipFile(out, mode="w", alignment=ZIP_ALIGNMENT) as archive:
            archive.comment = BUILD_ID
            for model, tflite in models.items():
                name = model.task_name.removesuffix(".tflite")
                meta = image_model_metadata(tflite, name, model.mean, model.std)
                info = zipfile.ZipInfo(model.task_name, date_time=ZIP_TIME)
                archive.writestr(info, with_metadata(tflite, meta))
        out.seek(0)
        return out.read()


def build(out: Path | None = None, wheel: Path | None = None) -> Path:
    """Build the pose landmarker .task at `out` (default `default_path()`); returns its path."""
    out = out or default_path()
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="carlaverse-pose-") as scratch:
        bundle = task_bundle(extract_models(wheel or download_wheel(Path(scratch))))
    # written beside the target and renamed, so a reader never sees half a file
    partial = out.with_name(f".{out.name}.{os.getpid()}.partial")
    partial.write_bytes(bundle)
    os.replace(partial, out)
    return out


def require(path: Path | None = None) -> Path:
    """The built model's path, or PoseModelError saying how to (re)build it."""
    path = path or default_path()
    build = "`carlaverse body build-model` (needs the body extra)"
    if not path.is_file():
        raise PoseModelError(f"pose model {path} is missing; build it once with {build}")
    try:
        with zipfile.ZipFile(path) as bundle:
            comment = bundle.comment
    except (OSError, zipfile.BadZipFile) as exc:
        raise PoseModelError(f"pose model {path} is unreadable ({exc}); rebuild it with {build}")  # noqa: B904 (the cause is in the line)
    if comment != BUILD_ID:
        raise PoseModelError(f"pose model {path} was not made by this version's build; "
                             f"rebuild it with {build}")  # fmt: skip
    return path
