"""Spatial audio on the node (CARLAcoustics): the authority's emitters, rendered locally.

    renderer = build_renderer(AudioConfig(layout="binaural"))   # renderer.py
    renderer.place(listener); renderer.hear(scene.emitters, scene.t)
    block = renderer.render_block()                              # block × channels, ±1

Rooms: `sources` (procedural generators, `voicing` their constants, `noise`, `wavetables`),
`propagation` (travel time, Doppler delay lines), `air` (ISO 9613-1), `binaural` (HRTF,
`hrtf` loads the sets), `panning` (VBAP), `scene` (emitter slots), `listener`, `limiter`,
`offline` (a recording to WAV). Nothing here imports sounddevice except the real-time output.
"""
