# Blender reads vsd's multilayer EXR as render passes (docs/architecture.md §6).
#
# Run by ctest as:
#   blender --background --factory-startup --python-exit-code 1 \
#           --python tests/blender_exr_passes.py -- <test_image> <out.exr>
# test_image --write-sample writes a 6x4 EXR whose values follow sample_value() below (the
# same formula as in tests/test_image.c). Blender must load it as a MULTILAYER image, offer
# every pass as an output of a compositor Image node, and deliver the exact values through
# the compositor: each pass is routed to the Composite node, rendered to a plain float EXR,
# and read back with Blender's own image loader. (The Viewer node's pixels stay empty in
# --background mode, hence the detour through a file.)
import os
import subprocess
import sys

import bpy

W, H = 6, 4
PASSES = ["Combined", "VolumeDir", "VolumeInd", "Emit", "Transmittance", "Depth"]


def sample_value(p, c, x, y):
    """Value of pass index p, channel c at pixel (x, y), y = 0 the top row."""
    if PASSES[p] == "Depth":
        return 2.0 + x + 10.0 * y
    return 0.125 * (p + 1) + 0.03125 * c + 0.0078125 * x + 0.001953125 * y


def expected_rgba(output, x, y):
    """What the Composite node receives from the Image node's `output` socket."""
    if output in ("Combined", "Image"):
        return [sample_value(0, c, x, y) for c in range(4)]
    if output == "Alpha":
        a = sample_value(0, 3, x, y)
        return [a, a, a, 1.0]
    if output == "Depth":
        z = sample_value(5, 0, x, y)
        return [z, z, z, 1.0]
    p = PASSES.index(output)
    return [sample_value(p, c, x, y) for c in range(3)] + [1.0]


def render_output(scene, tree, image_node, composite, output, path):
    """Route one Image-node output to the Composite node and return its pixels as Blender
    loads them back: flat RGBA floats, bottom row first."""
    tree.links.new(image_node.outputs[output], composite.inputs["Image"])
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    result = bpy.data.images.load(path)
    assert tuple(result.size) == (W, H), f"{output}: rendered size {tuple(result.size)}"
    pixels = result.pixels[:]
    bpy.data.images.remove(result)
    os.remove(path)
    return pixels


def check_values(output, pixels):
    bad = []
    for yb in range(H):
        y = H - 1 - yb  # Blender's rows start at the bottom, ours at the top
        for x in range(W):
            got = pixels[(yb * W + x) * 4:(yb * W + x) * 4 + 4]
            want = expected_rgba(output, x, y)
            if any(abs(g - w) > 1e-6 * max(1.0, abs(w)) for g, w in zip(got, want)):
                bad.append((x, y, [round(v, 6) for v in got], want))
    assert not bad, f"{output}: {len(bad)} pixel(s) differ, first: {bad[0]}"


def setup_scene():
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"  # the 3D render is irrelevant; only compositing
    scene.render.resolution_x = W
    scene.render.resolution_y = H
    scene.render.resolution_percentage = 100
    scene.render.use_compositing = True
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.image_settings.color_depth = "32"
    scene.use_nodes = True
    tree = scene.node_tree
    for node in list(tree.nodes):
        tree.nodes.remove(node)
    return scene, tree


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    test_image, path = argv[0], argv[1]
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    subprocess.run([test_image, "--write-sample", path], check=True)

    scene, tree = setup_scene()
    img = bpy.data.images.load(path)
    image_node = tree.nodes.new("CompositorNodeImage")
    image_node.image = img  # assigning makes Blender read the file and its layers
    composite = tree.nodes.new("CompositorNodeComposite")

    assert img.type == "MULTILAYER", f"image type {img.type}, expected MULTILAYER"
    outputs = [s.name for s in image_node.outputs]
    print("Image node outputs:", outputs)
    combined = "Combined" if "Combined" in outputs else "Image"  # Blender < 3.4 says Image
    for name in [combined, "Alpha", "VolumeDir", "VolumeInd", "Emit", "Transmittance", "Depth"]:
        assert name in outputs, f"no '{name}' output on the Image node: {outputs}"

    base = os.path.splitext(path)[0]
    for name in [combined, "Alpha", "VolumeDir", "VolumeInd", "Emit", "Transmittance", "Depth"]:
        check_values(name, render_output(scene, tree, image_node, composite, name,
                                         f"{base}_{name}.exr"))
        print(f"{name}: {W}x{H} values match")
    print("blender_exr_passes: all checks passed")


main()
