"""First-person rendering of the shared world (Panda3D), fed only through the world view.

Rooms, each with one job (Panda3D is imported only inside this package, and only by the
modules that draw; `rig`, `frame` and `weather.lighting` maths need no GPU):

    rig              camera rigs from YAML: simple / physical (the paper's f and o_i) / manual
    frame            what one frame shows, taken from a WorldView at one time
    graphics         the Panda3D engine: windows or offscreen buffers, pixels out
    cameras          the rig in the scene: anchor, head, one camera per display region
    meshes           triangle meshes: ribbons, polygons, prisms, boxes, spheres (textured or not)
    textures         procedural textures: asphalt, paving, kerb, grass, paint, facades, lit windows
    scene_static     the map's static meshes, built once (the rooms below)
    scene_roads      asphalt, sidewalks with kerbs, bike lanes, junctions
    scene_markings   paint after SUMO's lane rules: edge/lane/centre lines, stop, give-way, zebras
    scene_areas      ground, parks, water
    scene_buildings  facades with windows per floor, doors to the street, lit-window stage
    scene_trees      trees in parks (Poisson disc) and along streets, round lumpy crowns
    signs            where speed limit, stop and give-way signs stand (from the map's lanes)
    sign_faces       sign faces drawn with Pillow into one atlas
    scene_signs      the signs' poles and faces
    clearance        distances from points to lanes (trees off roads, street-facing walls)
    traffic_lights   a signal head per controlled link, lit from the lights' state
    actors           egos and NPCs by kind at their extents, brake lamps and blinkers
    figure           walkers articulated from their Skeleton (joint convention documented)
    weather          sun, sky, fog, clouds, wet roads
    renderer         ties the rooms together: build once, draw a frame, read images
    recording        a world view fed from an MCAP recording, for stills and clips
    live             a live session for the view: observer client, own pose from shm, skeletons
    process          the node's view in a render process of its own (`join KIND --view`)
    video            MP4 clips through ffmpeg (imageio-ffmpeg)
    carla_bridge     CARLA as a second backend: actors and cameras mirrored into a server
"""
