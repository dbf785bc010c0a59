"""Render one frame of a slothsim glb with Blender (headless) and check that
the sloth shows.

    blender -b --python tools/view/render_glb.py -- IN.glb OUT.png [TIME_S]

Imports the glb (Blender's own glTF importer), sets the frame for TIME_S
seconds of the run's animation (default: its middle), frames a camera on the
first recorded sloth (the skinned mesh, as deformed at that frame) and
renders OUT.png with Workbench (no GPU needed). Then renders the same view
with the sloths hidden and counts the pixels that differ: fewer than 1 % of
the image (a blank, missing or off-screen sloth) exits 1.
"""

import math
import sys

import bpy
import numpy
from mathutils import Vector

# Debian's Blender 3.4 glTF importer uses `numpy.bool`, gone since numpy 1.24.
if "bool" not in numpy.__dict__:
    numpy.bool = bool

argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
if len(argv) < 2:
    print("usage: blender -b --python render_glb.py -- IN.glb OUT.png [TIME_S]")
    sys.exit(2)
glb, png = argv[0], argv[1]
time_s = float(argv[2]) if len(argv) > 2 else None

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=glb)
scene = bpy.context.scene
fps = scene.render.fps / scene.render.fps_base

# The animation's range (the importer puts the actions on the armatures).
actions = list(bpy.data.actions)
if actions:
    start = min(a.frame_range[0] for a in actions)
    end = max(a.frame_range[1] for a in actions)
    frame = (start + end) / 2 if time_s is None else time_s * fps
    frame = min(max(frame, start), end)
else:
    frame = scene.frame_current
scene.frame_set(int(round(frame)))

sloths = [
    o for o in scene.objects
    if o.type == "MESH" and any(m.type == "ARMATURE" for m in o.modifiers)
]
if not sloths:
    print("FAIL: no skinned sloth mesh in", glb)
    sys.exit(1)
sloths.sort(key=lambda o: o.name)
focus = sloths[0]
deps = bpy.context.evaluated_depsgraph_get()
ev = focus.evaluated_get(deps)
mesh = ev.to_mesh()
pts = [ev.matrix_world @ v.co for v in mesh.vertices]
ev.to_mesh_clear()
centre = sum(pts, Vector()) / len(pts)
radius = max((p - centre).length for p in pts)

cam_data = bpy.data.cameras.new("view")
cam_data.lens = 50
cam = bpy.data.objects.new("view", cam_data)
scene.collection.objects.link(cam)
scene.camera = cam
# From the side, a little below and ahead (sloths hang under their branch).
# Blender is Z-up: the importer turned glTF +Y up into +Z.
direction = Vector((0.75, -0.55, -0.35)).normalized()
fov = 2 * math.atan(cam_data.sensor_width / (2 * cam_data.lens))
cam.location = centre + direction * (radius / math.sin(fov / 2) * 1.15)
cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
cam_data.clip_start = 0.01
cam_data.clip_end = 1000

scene.render.engine = "BLENDER_WORKBENCH"
scene.display.shading.light = "STUDIO"
scene.display.shading.color_type = "MATERIAL"
scene.display.shading.show_cavity = True
world = bpy.data.worlds.new("sky")
world.color = (0.62, 0.75, 0.85)
scene.world = world
scene.render.resolution_x = 800
scene.render.resolution_y = 600
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "PNG"


def render(path):
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = list(img.pixels)
    bpy.data.images.remove(img)
    return px


with_sloth = render(png)
for o in sloths:
    o.hide_render = True
without = render(png + ".bg.png")
for o in sloths:
    o.hide_render = False
n = len(with_sloth) // 4
differ = sum(
    1
    for i in range(n)
    if max(abs(with_sloth[4 * i + c] - without[4 * i + c]) for c in range(3)) > 0.05
)
share = differ / n
print(f"rendered {png} at frame {scene.frame_current} ({scene.frame_current / fps:.2f} s): "
      f"{len(sloths)} sloth(s), the focus sloth covers {100 * share:.1f} % of the image")
if share < 0.01:
    print("FAIL: the sloth does not show")
    sys.exit(1)
