"""Live and recorded views of a session in Rerun (docs/architecture.md §11): `carlaverse view`.

`world` keeps the latest state of a session (fed from Zenoh callbacks or a recording),
`scene` turns it into Rerun entities on the `sim_time` timeline, `live` and `playback` are
the two sources, and `outputs` connects a recording stream to a viewer, web viewer or file.
"""
