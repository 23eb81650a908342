"""Input-normalization metadata written into a TFLite model, as MediaPipe Tasks expects it.

A Tasks graph reads how to scale pixels into the model's input tensor from the model's
`TFLITE_METADATA` (an image input with NormalizationOptions); the legacy pose models carry
none (the landmark model) or another model's (the detector's says "Full Range Face
Detection"). The metadata itself is made by mediapipe's own metadata writers
(`metadata_info`); it is packed into the model here with the flatbuffer schema mediapipe
ships, the steps of mediapipe's `MetadataPopulator`, because mediapipe 1.x's populator
imports a compiled helper (`_pywrap_metadata_version`) that its wheels do not contain. That
helper only computes the minimum parser version, which is 1.0.0 for metadata that uses
nothing newer than image properties and normalization.
"""

from __future__ import annotations

import flatbuffers
from mediapipe.tasks.metadata import metadata_schema_py_generated as metadata_fb
from mediapipe.tasks.metadata import schema_py_generated as tflite_fb
from mediapipe.tasks.python.metadata.metadata_writers import metadata_info, writer_utils

METADATA_FIELD = b"TFLITE_METADATA"
METADATA_IDENTIFIER = b"M001"
MODEL_IDENTIFIER = b"TFL3"
MIN_PARSER_VERSION = "1.0.0"
BUFFER_ALIGNMENT = 16  # [bytes] so TFLite can map weights in place instead of copying them


class _AlignedBuffer(tflite_fb.BufferT):
    """A model buffer packed at a 16-byte boundary (the object API packs bytes unaligned)."""

    def Pack(self, builder: flatbuffers.Builder) -> int:
        data = None
        if self.data is not None and len(self.data):
            payload = bytes(self.data)
            builder.StartVector(1, len(payload), BUFFER_ALIGNMENT)
            builder.head -= len(payload)
            builder.Bytes[builder.head : builder.head + len(payload)] = payload
            builder.vectorNumElems = len(payload)  # EndVector reads it
            data = builder.EndVector()
        tflite_fb.BufferStart(builder)
        if data is not None:
            tflite_fb.BufferAddData(builder, data)
        tflite_fb.BufferAddOffset(builder, self.offset)
        tflite_fb.BufferAddSize(builder, self.size)
        return tflite_fb.BufferEnd(builder)


def image_model_metadata(model: bytes, name: str, mean: float, std: float) -> bytes:
    """ModelMetadata for a one-image-input model: input = (pixel − mean) / std, RGB."""
    image = metadata_info.InputImageTensorMd(
        name="image",
        description="RGB image",
        norm_mean=[mean],
        norm_std=[std],
        color_space_type=metadata_fb.ColorSpaceType.RGB,
        tensor_type=writer_utils.get_input_tensor_types(model)[0],
    )
    outputs = writer_utils.get_output_tensor_types(model)
    subgraph = metadata_fb.SubGraphMetadataT()
    subgraph.inputTensorMetadata = [image.create_metadata()]
    subgraph.outputTensorMetadata = [
        metadata_info.TensorMd(name=f"output_{i}").create_metadata() for i in range(len(outputs))
    ]
    general = metadata_info.GeneralMd(name=name, description=f"{name} (MediaPipe Pose)")
    metadata = general.create_metadata()
    metadata.subgraphMetadata = [subgraph]
    metadata.minParserVersion = MIN_PARSER_VERSION
    builder = flatbuffers.Builder(0)
    builder.Finish(metadata.Pack(builder), METADATA_IDENTIFIER)
    return bytes(builder.Output())


def with_metadata(model: bytes, metadata: bytes) -> bytes:
    """The model with `metadata` as its TFLITE_METADATA, replacing any it had."""
    tree = tflite_fb.ModelT.InitFromObj(tflite_fb.Model.GetRootAsModel(model, 0))
    buffer = _AlignedBuffer()
    buffer.data = metadata
    tree.buffers = [_aligned(b) for b in tree.buffers or []]
    tree.metadata = [m for m in tree.metadata or [] if m.name != METADATA_FIELD]
    tree.buffers.append(buffer)
    field = tflite_fb.MetadataT()
    field.name = METADATA_FIELD.decode()
    field.buffer = len(tree.buffers) - 1
    tree.metadata.append(field)
    builder = flatbuffers.Builder(len(model) + len(metadata) + 4096)
    builder.Finish(tree.Pack(builder), MODEL_IDENTIFIER)
    return bytes(builder.Output())


def _aligned(buffer: tflite_fb.BufferT) -> _AlignedBuffer:
    aligned = _AlignedBuffer()
    aligned.data, aligned.offset, aligned.size = buffer.data, buffer.offset, buffer.size
    return aligned


def read_normalization(model: bytes) -> tuple[str, float, float] | None:
    """(model name, mean, std) of the first input's normalization, or None without metadata."""
    root = tflite_fb.Model.GetRootAsModel(model, 0)
    for i in range(root.MetadataLength()):
        entry = root.Metadata(i)
        if entry.Name() != METADATA_FIELD:
            continue
        raw = root.Buffers(entry.Buffer()).DataAsNumpy().tobytes()
        meta = metadata_fb.ModelMetadataT.InitFromObj(
            metadata_fb.ModelMetadata.GetRootAsModelMetadata(raw, 0)
        )
        options = meta.subgraphMetadata[0].inputTensorMetadata[0].processUnits[0].options
        return meta.name.decode(), float(options.mean[0]), float(options.std[0])
    return None
