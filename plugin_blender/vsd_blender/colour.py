# Colour spaces: which space Blender renders in, and whether an image needs converting to it.
#
# Blender's render results and shader colours are in its *working space*: the OCIO config's
# scene_linear role up to 4.5 (named "Linear" in 3.4's config, "Linear Rec.709" from 4.0),
# and from 5.0 the blend file's own choice (bpy.data.colorspace.working_space: Linear
# Rec.709, Linear Rec.2020 or ACEScg). vsd renders in whatever space its inputs are in, so
# the add-on keeps everything in the working space: material and light colours already are,
# the environment map is converted by the daemon from its own space to the working space
# (scene file `environment.colorspace` -> `environment.working_space`, with OpenColorIO), and
# the passes that come back are tagged with the working space.
import bpy

# Spaces whose pixels are numbers, not colours: never converted.
DATA_SPACES = {"non-color", "raw", "data"}


def working_space():
    """The name of Blender's working space in its own OCIO config."""
    cs = getattr(bpy.data, "colorspace", None)          # 5.0+: per blend file
    if cs is not None and getattr(cs, "working_space", ""):
        return cs.working_space
    names = image_space_names()
    for name in ("Linear Rec.709", "Linear"):           # 4.x, 3.x configs
        if name in names:
            return name
    return "scene_linear"


def image_space_names():
    """The colour space names an image can be tagged with in this Blender."""
    prop = bpy.types.ColorManagedInputColorspaceSettings.bl_rna.properties["name"]
    return [i.identifier for i in prop.enum_items]


def image_space_for_results():
    """The name to tag a render result loaded as an image with (the viewport preview):
    the working space, which Blender's image colour spaces list by that name."""
    ws = working_space()
    names = image_space_names()
    if ws in names:
        return ws
    return "scene_linear" if "scene_linear" in names else names[0]


def needs_conversion(space, working):
    """Whether pixels tagged `space` must be converted to reach `working`."""
    if not space:
        return False
    s = space.strip().lower()
    return s not in DATA_SPACES and s not in ("scene_linear", working.strip().lower())
